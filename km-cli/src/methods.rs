//! Dispatch of `km solve` to the method libraries.

use anyhow::{Result, bail};
use km_core::{Scene, Solution};

use crate::{KmMappingArg, Method, SolveArgs};

/// Solve `scene` with the method and options of `args`.
pub fn solve(scene: &Scene, args: &SolveArgs) -> Result<Solution> {
    match args.method {
        Method::Km => {
            let _ = args.km_mapping == KmMappingArg::Seed;
            bail!("method km is coming: not available in this build")
        }
        m => bail!("method {} is coming: not available in this build", m.name()),
    }
}
