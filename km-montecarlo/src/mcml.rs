//! MCML's files: the input format `.mci` (every run of a file) and the
//! ASCII output format `.mco` (format `A1`, all sections: InParm, RAT, A_l,
//! A_z, Rd_r, Rd_a, Tt_r, Tt_a, A_rz, Rd_ra, Tt_ra), as MCML 1.2 (Wang,
//! Jacques & Zheng 1995, §9–10 of its manual) reads and writes them.
//! docs/mcml.md states the formats, the normalisations and what differs.

use std::fmt::Write;

use km_core::{Scene, Solution};

use crate::error::McError;
use crate::grid::{GridResult, McGrid};

/// Largest number of runs in one `.mci` file.
pub const MAX_RUNS: usize = 10_000;
/// Largest number of layers of one run.
pub const MAX_LAYERS: usize = 1_000;
/// Largest `nz`, `nr`, `na`: MCML stores them as C `short`.
pub const MAX_AXIS: usize = 32_767;

/// One layer of an `.mci` run (lengths in cm, coefficients in 1/cm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MciLayer {
    /// Refractive index.
    pub n: f64,
    /// Absorption coefficient `mua`.
    pub mua: f64,
    /// Scattering coefficient `mus`.
    pub mus: f64,
    /// Henyey–Greenstein anisotropy.
    pub g: f64,
    /// Thickness.
    pub d: f64,
}

/// One run of an `.mci` file.
#[derive(Debug, Clone, PartialEq)]
pub struct MciRun {
    /// Output file name, as written in the file.
    pub out_name: String,
    /// Output format letter (`A`; MCML's binary `B` is written as ASCII too).
    pub format: char,
    /// Photons.
    pub photons: u64,
    /// Depth bin, cm.
    pub dz: f64,
    /// Radial bin, cm.
    pub dr: f64,
    /// Depth bins.
    pub nz: usize,
    /// Radial bins.
    pub nr: usize,
    /// Angle bins.
    pub na: usize,
    /// Index of the medium above.
    pub n_above: f64,
    /// The layers, top first.
    pub layers: Vec<MciLayer>,
    /// Index of the medium below.
    pub n_below: f64,
    /// 1-based line of the run's first data line.
    pub line: usize,
}

/// A parsed `.mci` file.
#[derive(Debug, Clone, PartialEq)]
pub struct MciFile {
    /// The file version (first data line, e.g. `1.0`).
    pub version: String,
    /// The runs, in file order.
    pub runs: Vec<MciRun>,
}

/// The data lines of a file: `(1-based line number, text before '#')`,
/// blank and comment lines skipped, as MCML's `FindDataLine` does.
struct Lines<'a> {
    it: std::iter::Enumerate<std::str::Lines<'a>>,
    last: usize,
}

impl<'a> Lines<'a> {
    fn next(&mut self, field: &'static str) -> Result<(usize, Vec<&'a str>), McError> {
        for (i, l) in self.it.by_ref() {
            self.last = i + 1;
            let data = l.split('#').next().unwrap_or("");
            let tokens: Vec<&str> = data.split_whitespace().collect();
            if !tokens.is_empty() {
                return Ok((i + 1, tokens));
            }
        }
        Err(mci(self.last + 1, field, "the file ends here (incomplete data)".into()))
    }
}

fn mci(line: usize, field: &'static str, reason: String) -> McError {
    McError::Mci { line, field, reason }
}

/// A number of field `field` on line `line`.
fn num(line: usize, field: &'static str, tokens: &[&str], k: usize) -> Result<f64, McError> {
    let Some(t) = tokens.get(k) else {
        return Err(mci(line, field, format!("missing (expected {} numbers)", k + 1)));
    };
    match t.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(mci(line, field, format!("{t:?} is not a finite number"))),
    }
}

/// A count (a non-negative integer, written as an integer or as an integral
/// number such as `1e6`) within `1..=max`.
fn count(
    line: usize,
    field: &'static str,
    tokens: &[&str],
    k: usize,
    max: u64,
) -> Result<u64, McError> {
    let x = num(line, field, tokens, k)?;
    if x.fract() != 0.0 || x < 1.0 || x > max as f64 {
        return Err(mci(line, field, format!("{x} is not a whole number in 1..={max}")));
    }
    Ok(x as u64)
}

/// Parse an `.mci` file (MCML 1.x input).
///
/// # Errors
/// [`McError::Mci`] naming the line and the field: a missing or malformed
/// number, a value outside its domain (`n >= 1`, `mua, mus, d >= 0`,
/// `0 <= g < 1`, `dz, dr > 0`, `nz, nr, na` in `1..=32767`, photons >= 1),
/// a duplicated output name, more than [`MAX_RUNS`] runs or [`MAX_LAYERS`] layers.
///
/// ```
/// let text = "1.0\n1\nout.mco A\n1000\n0.01 0.01\n10 10 1\n1\n1.0\n1.37 1 100 0.9 0.1\n1.0\n";
/// let f = km_montecarlo::mcml::parse_mci(text).unwrap();
/// assert_eq!(f.runs[0].layers[0].mus, 100.0);
/// ```
pub fn parse_mci(text: &str) -> Result<MciFile, McError> {
    let mut lines = Lines { it: text.lines().enumerate(), last: 0 };
    let (_, v) = lines.next("file version")?;
    let version = v[0].to_string();
    let (ln, t) = lines.next("number of runs")?;
    let runs = count(ln, "number of runs", &t, 0, MAX_RUNS as u64)? as usize;
    let mut out = Vec::with_capacity(runs);
    for _ in 0..runs {
        let run = parse_run(&mut lines)?;
        if let Some(prev) = out.iter().find(|r: &&MciRun| r.out_name == run.out_name) {
            return Err(mci(
                run.line,
                "output file name",
                format!("{:?} is also the output of the run on line {}", run.out_name, prev.line),
            ));
        }
        out.push(run);
    }
    Ok(MciFile { version, runs: out })
}

fn parse_run(lines: &mut Lines<'_>) -> Result<MciRun, McError> {
    let (line, t) = lines.next("output file name")?;
    let out_name = t[0].to_string();
    let format = t.get(1).and_then(|s| s.chars().next()).unwrap_or('A').to_ascii_uppercase();
    let (ln, t) = lines.next("number of photons")?;
    let photons = count(ln, "number of photons", &t, 0, u64::MAX >> 11)?;
    let (ln, t) = lines.next("dz, dr")?;
    let (dz, dr) = (num(ln, "dz", &t, 0)?, num(ln, "dr", &t, 1)?);
    for (x, f) in [(dz, "dz"), (dr, "dr")] {
        if x <= 0.0 {
            return Err(mci(ln, f, format!("{x} must be > 0")));
        }
    }
    let (ln, t) = lines.next("nz, nr, na")?;
    let axis = |k, f| count(ln, f, &t, k, MAX_AXIS as u64).map(|x| x as usize);
    let (nz, nr, na) = (axis(0, "nz")?, axis(1, "nr")?, axis(2, "na")?);
    let (ln, t) = lines.next("number of layers")?;
    let nl = count(ln, "number of layers", &t, 0, MAX_LAYERS as u64)? as usize;
    let n_above = index(lines, "n for medium above")?;
    let mut layers = Vec::with_capacity(nl);
    for _ in 0..nl {
        layers.push(parse_layer(lines)?);
    }
    let n_below = index(lines, "n for medium below")?;
    Ok(MciRun { out_name, format, photons, dz, dr, nz, nr, na, n_above, layers, n_below, line })
}

fn index(lines: &mut Lines<'_>, field: &'static str) -> Result<f64, McError> {
    let (ln, t) = lines.next(field)?;
    let n = num(ln, field, &t, 0)?;
    if n < 1.0 {
        return Err(mci(ln, field, format!("{n}: km needs refractive indices >= 1")));
    }
    Ok(n)
}

fn parse_layer(lines: &mut Lines<'_>) -> Result<MciLayer, McError> {
    let (ln, t) = lines.next("layer (n mua mus g d)")?;
    let l = MciLayer {
        n: num(ln, "layer n", &t, 0)?,
        mua: num(ln, "layer mua", &t, 1)?,
        mus: num(ln, "layer mus", &t, 2)?,
        g: num(ln, "layer g", &t, 3)?,
        d: num(ln, "layer d", &t, 4)?,
    };
    let checks: [(bool, &'static str, &str); 5] = [
        (l.n >= 1.0, "layer n", "km needs refractive indices >= 1"),
        (l.mua >= 0.0, "layer mua", "must be >= 0"),
        (l.mus >= 0.0, "layer mus", "must be >= 0"),
        (l.g >= 0.0 && l.g < 1.0, "layer g", "must lie in [0, 1) (g = 1 never scatters)"),
        (l.d > 0.0, "layer d", "must be > 0"),
    ];
    for (ok, field, why) in checks {
        if !ok {
            return Err(mci(ln, field, format!("{}: {why}", t.join(" "))));
        }
    }
    Ok(l)
}

impl MciRun {
    /// The run as a km scene (lengths in cm): layers with `sigma_a = mua`,
    /// `sigma_s = mus`, `g`, `n`, thickness `d`; the ambient index above;
    /// a transparent substrate of the index below; normal incidence.
    ///
    /// # Errors
    /// [`McError::Mci`] when km's scene checks refuse it.
    pub fn scene(&self) -> Result<Scene, McError> {
        let mut t = format!("[ambient]\nn = {:?}\n", self.n_above);
        for l in &self.layers {
            let _ = write!(
                t,
                "[[layer]]\nsigma_a = {:?}\nsigma_s = {:?}\ng = {:?}\nn = {:?}\nthickness = {:?}\n",
                l.mua, l.mus, l.g, l.n, l.d
            );
        }
        let _ = write!(t, "[substrate]\nkind = \"transparent\"\nn = {:?}\n", self.n_below);
        Scene::from_toml_str(&t)
            .map_err(|e| mci(self.line, "run", format!("not a valid km scene: {e}")))
    }

    /// The run's grid.
    pub fn grid(&self) -> McGrid {
        McGrid { dz: self.dz, nz: self.nz, dr: self.dr, nr: self.nr, na: self.na }
    }
}

/// C's `%E` with `prec` digits after the point and a two-digit exponent
/// (`2.7990E+00`), right-aligned in `width`.
pub fn c_e(x: f64, prec: usize, width: usize) -> String {
    let s = format!("{x:.prec$E}");
    let (m, e) = s.split_once('E').unwrap_or((&s, "0"));
    let e: i32 = e.parse().unwrap_or(0);
    let sign = if e < 0 { '-' } else { '+' };
    format!("{:>width$}", format!("{m}E{sign}{:02}", e.abs()))
}

/// C's `%G` (6 significant digits, trailing zeros removed).
pub fn c_g(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return if x == 0.0 { "0".into() } else { x.to_string() };
    }
    let e = format!("{x:.5E}");
    let exp: i32 = e.split_once('E').map_or(0, |(_, e)| e.parse().unwrap_or(0));
    let trim = |s: String| {
        if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s }
    };
    if !(-4..6).contains(&exp) {
        let (m, _) = e.split_once('E').unwrap_or((&e, ""));
        let sign = if exp < 0 { '-' } else { '+' };
        format!("{}E{sign}{:02}", trim(m.to_string()), exp.abs())
    } else {
        let decimals = (5 - exp).max(0) as usize;
        trim(format!("{x:.decimals$}"))
    }
}

/// One run's results in MCML's arrays and normalisations (docs/mcml.md):
/// overflow bins folded into the last bin, `Rd(a)` and `Tt(a)` per
/// `2 pi sin(a) da`, each value with its standard error (eq. T1).
#[derive(Debug, Clone, PartialEq)]
pub struct Mco {
    /// Specular reflectance (the launch's Fresnel reflection).
    pub rsp: f64,
    /// Diffuse reflectance, its standard error.
    pub rd: [f64; 2],
    /// Absorbed fraction, its standard error.
    pub a: [f64; 2],
    /// Total transmittance, its standard error.
    pub tt: [f64; 2],
    /// Absorption per layer (exact, not binned), and standard errors.
    pub a_l: [Vec<f64>; 2],
    /// `A(z)`, 1/cm, `nz` values, and standard errors.
    pub a_z: [Vec<f64>; 2],
    /// `Rd(r)`, 1/cm^2, `nr` values.
    pub rd_r: [Vec<f64>; 2],
    /// `Rd(a)`, 1/sr, `na` values.
    pub rd_a: [Vec<f64>; 2],
    /// `Tt(r)`, 1/cm^2.
    pub tt_r: [Vec<f64>; 2],
    /// `Tt(a)`, 1/sr.
    pub tt_a: [Vec<f64>; 2],
    /// `A(r, z)`, 1/cm^3, `[ir][iz]`, `nr x nz`.
    pub a_rz: [Vec<f64>; 2],
    /// `Rd(r, a)`, 1/(cm^2 sr), `[ir][ia]`.
    pub rd_ra: [Vec<f64>; 2],
    /// `Tt(r, a)`, 1/(cm^2 sr).
    pub tt_ra: [Vec<f64>; 2],
}

/// Fold the overflow entries of a row-major `(rows + 1) x cols` array (and,
/// with `fold_cols`, of `rows x (cols + 1)`) into the last row and column,
/// as MCML clamps indices; standard errors combine in quadrature (bins of
/// one photon's history are not independent, so this bounds them loosely;
/// the overflow bins are small where MCML's grid is sensible).
fn fold(v: &[f64], se: &[f64], rows: usize, cols: usize, fold_cols: bool) -> [Vec<f64>; 2] {
    let c_in = if fold_cols { cols + 1 } else { cols };
    let (mut m, mut s) = (vec![0.0; rows * cols], vec![0.0; rows * cols]);
    for r in 0..=rows {
        for c in 0..c_in {
            let k = (r.min(rows - 1)) * cols + c.min(cols - 1);
            m[k] += v[r * c_in + c];
            s[k] += se[r * c_in + c].powi(2);
        }
    }
    [m, s.into_iter().map(f64::sqrt).collect()]
}

impl Mco {
    /// MCML's arrays from a run's solution channel and grid result.
    pub fn new(run: &MciRun, sol: &Solution, g: &GridResult) -> Mco {
        use std::f64::consts::PI;
        let c = &sol.channels[0];
        let se = c.stderr.as_ref();
        let raw = &g.raw;
        let (nz, nr, na) = (run.nz, run.nr, run.na);
        let (dz, dr, da) = (run.dz, run.dr, g.grid.da());
        let scale = |a: [Vec<f64>; 2], f: &dyn Fn(usize) -> f64| -> [Vec<f64>; 2] {
            let [m, s] = a;
            let d: Vec<f64> = (0..m.len()).map(f).collect();
            [
                m.iter().zip(&d).map(|(x, d)| x / d).collect(),
                s.iter().zip(&d).map(|(x, d)| x / d).collect(),
            ]
        };
        let area = |ir: usize| 2.0 * PI * (ir as f64 + 0.5) * dr * dr;
        let omega = |ia: usize| 2.0 * PI * da * ((ia as f64 + 0.5) * da).sin();
        let ra = |k: usize| crate::grid::ra_norm(k / na, k % na, dr, da);
        let layers = c.absorptance_layers.clone().unwrap_or_default();
        let layers_se = se.and_then(|s| s.absorptance_layers.clone()).unwrap_or_default();
        let a_se = se.and_then(|s| s.absorptance).unwrap_or(f64::NAN);
        Mco {
            rsp: c.reflectance - g.rd,
            rd: [g.rd, g.rd_se],
            a: [c.absorptance, a_se],
            tt: [g.tt, g.tt_se],
            a_l: [layers, layers_se],
            a_z: scale(fold(&raw.a_z, &raw.a_z_se, nz, 1, false), &|_| dz),
            rd_r: scale(fold(&raw.rd_r, &raw.rd_r_se, nr, 1, false), &area),
            tt_r: scale(fold(&raw.tt_r, &raw.tt_r_se, nr, 1, false), &area),
            rd_a: scale([raw.rd_a.clone(), raw.rd_a_se.clone()], &omega),
            tt_a: scale([raw.tt_a.clone(), raw.tt_a_se.clone()], &omega),
            a_rz: scale(fold(&raw.a_rz, &raw.a_rz_se, nr, nz, true), &|k| area(k / nz) * dz),
            rd_ra: scale(fold(&raw.rd_ra, &raw.rd_ra_se, nr, na, false), &ra),
            tt_ra: scale(fold(&raw.tt_ra, &raw.tt_ra_se, nr, na, false), &ra),
        }
    }

    /// The `.mco` text (format `A1`) of `run` with these results, `photons`
    /// traced in `seconds`.
    pub fn text(&self, run: &MciRun, photons: u64, seconds: f64) -> String {
        let mut t = String::from("A1 \t# Version number of the file format.\n\n");
        t.push_str("####\n# Data categories include: \n# InParm, RAT, \n");
        t.push_str("# A_l, A_z, Rd_r, Rd_a, Tt_r, Tt_a, \n# A_rz, Rd_ra, Tt_ra \n####\n\n");
        let _ = writeln!(
            t,
            "# User time: {seconds:8.0} sec = {:8.2} hr.  Simulation time of this run.\n",
            seconds / 3600.0
        );
        t.push_str(&in_parm(run, photons));
        t.push_str("RAT #Reflectance, absorption, transmission. \n");
        let rat = [
            (self.rsp, "Specular reflectance"),
            (self.rd[0], "Diffuse reflectance"),
            (self.a[0], "Absorbed fraction"),
            (self.tt[0], "Transmittance"),
        ];
        for (x, what) in rat {
            let _ = writeln!(t, "{:<14} \t#{what} [-]", c_g(x));
        }
        t.push_str("\nA_l #Absorption as a function of layer. [-]\n");
        for x in &self.a_l[0] {
            let _ = writeln!(t, "{:>12}", c_g4(*x));
        }
        t.push('\n');
        let col = |t: &mut String, head: &str, v: &[f64]| {
            t.push_str(head);
            t.push('\n');
            for x in v {
                let _ = writeln!(t, "{}", c_e(*x, 4, 12));
            }
            t.push('\n');
        };
        col(&mut t, "A_z #A[0], [1],..A[nz-1]. [1/cm]", &self.a_z[0]);
        col(&mut t, "Rd_r #Rd[0], [1],..Rd[nr-1]. [1/cm2]", &self.rd_r[0]);
        col(&mut t, "Rd_a #Rd[0], [1],..Rd[na-1]. [sr-1]", &self.rd_a[0]);
        col(&mut t, "Tt_r #Tt[0], [1],..Tt[nr-1]. [1/cm2]", &self.tt_r[0]);
        col(&mut t, "Tt_a #Tt[0], [1],..Tt[na-1]. [sr-1]", &self.tt_a[0]);
        grid_section(&mut t, "A", "z", "[1/cm3]", "A_rz", &self.a_rz[0]);
        grid_section(&mut t, "Rd", "angle", "[1/(cm2sr)].", "Rd_ra", &self.rd_ra[0]);
        grid_section(&mut t, "Tt", "angle", "[1/(cm2sr)].", "Tt_ra", &self.tt_ra[0]);
        t
    }
}

/// `%12.4G` of `A_l`: 4 significant digits.
fn c_g4(x: f64) -> String {
    if x == 0.0 {
        return "0".into();
    }
    let exp = x.abs().log10().floor() as i32;
    if !(-4..4).contains(&exp) {
        let e = c_e(x, 3, 0);
        let (m, ex) = e.split_once('E').unwrap_or((&e, "+00"));
        let m = if m.contains('.') { m.trim_end_matches('0').trim_end_matches('.') } else { m };
        return format!("{m}E{ex}");
    }
    let decimals = (3 - exp).max(0) as usize;
    let s = format!("{x:.decimals$}");
    if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s }
}

/// The InParm section.
fn in_parm(run: &MciRun, photons: u64) -> String {
    let mut t = String::from("InParm \t\t\t# Input parameters. cm is used.\n");
    let _ = writeln!(t, "{} \tA\t\t# output file name, ASCII.", run.out_name);
    let _ = writeln!(t, "{photons} \t\t\t# No. of photons");
    let _ = writeln!(t, "{}\t{}\t\t# dz, dr [cm]", c_g(run.dz), c_g(run.dr));
    let _ = writeln!(t, "{}\t{}\t{}\t# No. of dz, dr, da.\n", run.nz, run.nr, run.na);
    let _ = writeln!(t, "{}\t\t\t\t\t# Number of layers", run.layers.len());
    t.push_str("#n\tmua\tmus\tg\td\t# One line for each layer\n");
    let _ = writeln!(t, "{}\t\t\t\t\t# n for medium above", c_g(run.n_above));
    for (i, l) in run.layers.iter().enumerate() {
        let v = [l.n, l.mua, l.mus, l.g, l.d].map(c_g);
        let _ = writeln!(t, "{}\t# layer {}", v.join("\t"), i + 1);
    }
    let _ = writeln!(t, "{}\t\t\t\t\t# n for medium below\n", c_g(run.n_below));
    t
}

/// A 2-D section, five numbers a line, as MCML's `WriteA_rz`/`WriteRd_ra`.
fn grid_section(t: &mut String, q: &str, axis: &str, unit: &str, name: &str, v: &[f64]) {
    let (first, last) = if axis == "z" { ("nz", "nz-1") } else { ("na", "na-1") };
    let _ = first;
    let _ = writeln!(t, "# {q}[r][{axis}]. {unit}");
    let _ = writeln!(t, "# {q}[0][0], [0][1],..[0][{last}]");
    let _ = writeln!(t, "# {q}[1][0], [1][1],..[1][{last}]");
    let _ = writeln!(t, "# ...");
    let _ = writeln!(t, "# {q}[nr-1][0], [nr-1][1],..[nr-1][{last}]");
    t.push_str(name);
    t.push('\n');
    for (k, x) in v.iter().enumerate() {
        t.push_str(&c_e(*x, 4, 12));
        t.push(' ');
        if (k + 1) % 5 == 0 {
            t.push('\n');
        }
    }
    t.push('\n');
}

/// Fewest batches of an MCML run: the standard errors need a few tens.
pub const MIN_BATCHES: u64 = 20;

/// Trace one `.mci` run: `photons` photons (the file's count unless given),
/// the other settings from `opts` (seed, threads, budget), the grid of the
/// run, and a batch count chosen so that the kept batch sums (twice
/// `batches x sums` `f64`s: the batch records and their statistics) stay
/// within `opts.max_tally_bytes`: at most 1000 batches, at least
/// [`MIN_BATCHES`].
///
/// # Errors
/// [`McError::TooMuchMemory`] when even [`MIN_BATCHES`] batches do not fit,
/// and those of [`crate::solve_grid`].
pub fn run_mci(
    run: &MciRun,
    photons: Option<u64>,
    opts: &crate::McOptions,
) -> Result<(Mco, Solution, GridResult), McError> {
    let scene = run.scene()?;
    let grid = run.grid();
    grid.validate()?;
    let photons = photons.unwrap_or(run.photons);
    let sums = (grid.sums() + 8 + 2 * run.layers.len()) as u64;
    let fit = opts.max_tally_bytes / (16 * sums).max(1);
    let batches = fit.min(1000).min(photons);
    if batches < MIN_BATCHES.min(photons) {
        return Err(McError::TooMuchMemory {
            bytes: (16 * sums * MIN_BATCHES) as f64,
            budget: opts.max_tally_bytes as f64,
            hint: format!(
                "the grid nz x nr x na = {} x {} x {} needs {sums} sums per batch and at least \
                 {MIN_BATCHES} batches: use a coarser grid or raise the tally budget",
                run.nz, run.nr, run.na
            ),
        });
    }
    let o = crate::McOptions {
        samples: photons,
        batch_size: Some(photons.div_ceil(batches.max(1))),
        grid: Some(grid),
        radial: None,
        ring_mu_edges: None,
        ..opts.clone()
    };
    let (sol, mut g) = crate::solve_grid(&scene, &o)?;
    let g = g.remove(0);
    Ok((Mco::new(run, &sol, &g), sol, g))
}
