//! Write an iad `.rxt` file of synthetic measurements made with km's
//! forward model (0 spheres, sample n = 1.4 between slides n = 1.5,
//! thickness 1 mm, g = 0), the truth in each row's comment.
//!
//! `cargo run -p km-inverse --example synthetic_rxt > examples/fit-synthetic.rxt`

use km_inverse::forward::{Optical, Sample};
use km_inverse::slab::{Setup, model};

fn main() -> Result<(), km_inverse::InverseError> {
    let set = Setup::new(Sample::new(1.0, 1.4, Some(1.5))?);
    println!("IAD1   # Must be first four characters");
    println!("# Synthetic measurements from km's multi-flux model at 64 streams");
    println!("1.4   # Index of refraction of the sample");
    println!("1.5   # Index of refraction of the top and bottom slides");
    println!("1.0   # [mm] Thickness of sample");
    println!("1.0   # [mm] Thickness of slides");
    println!("1.0   # [mm] Diameter of illumination beam");
    println!("1.0   # Reflectivity of the reflectance calibration standard");
    println!("0     # Number of spheres used at a time to make a measurement");
    println!("200 25 12 1 0.98  # reflection sphere (unused)");
    println!("200 25 12 1 0.98  # transmission sphere (unused)");
    println!("r t   # columns: M_R M_T");
    for a in [0.8, 0.9, 0.95, 0.99] {
        for b in [0.5, 1.0, 2.0, 4.0, 8.0] {
            let m = model(&set, &Optical { albedo: a, tau: b, g: 0.0 }, 64)?;
            println!("{:.8} {:.8}  # a = {a}, b = {b}, g = 0", m[0], m[1]);
        }
    }
    Ok(())
}
