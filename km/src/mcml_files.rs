//! The files of an MCML run (`km mc`, docs/mcml.md): where a run's `.mco`
//! and `.npz` go ([`out_paths`], refusing to write outside the output
//! directory, over the input or over another kind of file) and the `.npz`
//! of its arrays with their standard errors ([`npz_bytes`]).

use std::path::{Path, PathBuf};

use km_montecarlo::GridResult;
use km_montecarlo::mcml::{MciRun, Mco};
use km_multiflux::bsdf::write::{npy, zip_stored};

/// The `.mco` and `.npz` paths of a run: its output name under `--out-dir`;
/// refused when absolute or climbing out (`..`), when it is the input file,
/// or when an existing file there is not an `.mco` (or `.npz`) one.
///
/// # Errors
/// Those refusals, as `std::io::Error`s of kind `Other`.
pub fn out_paths(
    input: &Path,
    out_dir: &Path,
    run: &MciRun,
) -> std::io::Result<(PathBuf, PathBuf)> {
    let bail = |m: String| Err(std::io::Error::other(m));
    let name = Path::new(&run.out_name);
    let climbs = name.components().any(|c| !matches!(c, std::path::Component::Normal(_)));
    if climbs {
        return bail(format!(
            "{}: line {}: output file name {:?} must be a relative path below --out-dir",
            input.display(),
            run.line,
            run.out_name
        ));
    }
    let mco = out_dir.join(name);
    let npz = mco.with_extension("npz");
    let input = std::fs::canonicalize(input).ok();
    for (p, magic) in [(&mco, &b"A1"[..]), (&npz, &b"PK"[..])] {
        if std::fs::canonicalize(p).ok().is_some_and(|c| Some(c) == input) {
            let p = p.display();
            return bail(format!("{p}: the output of line {} is the input file itself", run.line));
        }
        if p.exists() && !starts_with(p, magic) {
            return bail(format!(
                "{}: exists and is not an {} file: not overwritten",
                p.display(),
                if magic == b"A1" { "MCML output (.mco)" } else { "npz" }
            ));
        }
    }
    Ok((mco, npz))
}

fn starts_with(p: &Path, magic: &[u8]) -> bool {
    use std::io::Read;
    let mut head = vec![0u8; magic.len()];
    std::fs::File::open(p).and_then(|mut f| f.read_exact(&mut head)).is_ok() && head == magic
}

/// An array and its standard errors.
type Pair = [Vec<f64>; 2];

/// The `.npz` of a run: MCML's arrays and their standard errors (`_se`),
/// the bin centres, `phi_z` and `flux_z` (docs/mcml.md).
pub fn npz_bytes(run: &MciRun, m: &Mco, g: &GridResult) -> Vec<u8> {
    let f64s = |v: &[f64]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let (nz, nr, na) = (run.nz, run.nr, run.na);
    let da = g.grid.da();
    let mut e: Vec<(String, Vec<u8>)> = Vec::new();
    let mut put = |name: &str, shape: &[usize], v: &[f64]| {
        e.push((format!("{name}.npy"), npy("<f8", shape, &f64s(v))));
    };
    put("z", &[nz], &(0..nz).map(|i| (i as f64 + 0.5) * run.dz).collect::<Vec<_>>());
    put("r", &[nr], &(0..nr).map(|i| (i as f64 + 0.5) * run.dr).collect::<Vec<_>>());
    put("alpha", &[na], &(0..na).map(|i| (i as f64 + 0.5) * da).collect::<Vec<_>>());
    put("rat", &[4], &[m.rsp, m.rd[0], m.a[0], m.tt[0]]);
    put("rat_se", &[4], &[0.0, m.rd[1], m.a[1], m.tt[1]]);
    let arrays: [(&str, &Pair, Vec<usize>); 9] = [
        ("a_l", &m.a_l, vec![run.layers.len()]),
        ("a_z", &m.a_z, vec![nz]),
        ("rd_r", &m.rd_r, vec![nr]),
        ("rd_a", &m.rd_a, vec![na]),
        ("tt_r", &m.tt_r, vec![nr]),
        ("tt_a", &m.tt_a, vec![na]),
        ("a_rz", &m.a_rz, vec![nr, nz]),
        ("rd_ra", &m.rd_ra, vec![nr, na]),
        ("tt_ra", &m.tt_ra, vec![nr, na]),
    ];
    for (name, [v, se], shape) in arrays {
        put(name, &shape, v);
        put(&format!("{name}_se"), &shape, se);
    }
    put("phi_z", &[nz + 1], &g.phi_z);
    put("phi_z_se", &[nz + 1], &g.phi_z_se);
    put("flux_z", &[nz + 1], &g.flux_z);
    put("flux_z_se", &[nz + 1], &g.flux_z_se);
    zip_stored(&e)
}
