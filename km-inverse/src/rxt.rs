//! Measurement files: iad's `.rxt` format and a plain CSV of spectra
//! (`docs/inverse.md` §5).
//!
//! **`.rxt`** (Prahl, iad manual, "Input file format"): the first four
//! characters are `IAD1`; `#` starts a comment to the end of the line. Then
//! 17 numbers: sample index, slide index, sample thickness, slide
//! thickness, beam diameter, reflectance of the standard, number of spheres
//! (0, 1, 2), the reflection sphere (diameter, sample port, entrance port,
//! detector port, wall reflectance), the transmission sphere (diameter,
//! sample port, exit port, detector port, wall reflectance). Then a legend
//! line: either one digit `k` (each row is an optional wavelength, then
//! `M_R`, then up to `M_T`, `M_U` as `k` says: a first value above 1 is the
//! wavelength) or column letters (`L` wavelength, `r` `M_R`, `t` `M_T`,
//! `u` `M_U`, `g`, `d`, `n`, `N`, `R`, `T`, `w`, `W`, `c`, `C`, `i`, `S`, ...).
//! Then the rows, read number by number.
//!
//! **CSV**: a header naming the columns (`wavelength_nm`, `m_r`, `m_t`, and
//! optionally `m_u`, `sigma_r`, `sigma_t`, `sigma_u`, `g`), comma separated,
//! `#` comments; the sample comes from the caller.

use crate::InverseError;
use crate::forward::Sample;
use crate::slab::{Measurement, Setup};
use crate::sphere::{Sphere, SphereSetup};

/// One row of a spectrum: everything one fit needs.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// Wavelength in nm, when the file gives one.
    pub wavelength_nm: Option<f64>,
    /// The set-up (sample, slides, spheres) at this row.
    pub setup: Setup,
    /// The measurement. A row with `M_R` alone has `m_t = 0` there and
    /// [`Row::reflectance_only`] set: its `m_t` is not a measurement.
    pub measurement: Measurement,
    /// The row gives `M_R` alone (an `.rxt` legend `1` or without `t`): a
    /// reflectance-only fit with a fixed quantity (iad's `-F`;
    /// [`crate::spectrum::RowFixed`]), `docs/inverse.md` §7.
    pub reflectance_only: bool,
    /// A fixed `g` given by the row (`None`: the caller's choice).
    pub g: Option<f64>,
    /// What the file gives that the fit does not model (beam diameter, lost
    /// light), in words; added to the row's fit notes.
    pub notes: Vec<String>,
}

/// Strip `#` comments; return the lines with their 1-based numbers.
fn clean_lines(text: &str) -> Vec<(usize, String)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.split('#').next().unwrap_or("").to_string()))
        .collect()
}

/// Parse an iad `.rxt` file.
///
/// # Errors
/// [`InverseError::Parse`] with the line for a missing magic, a bad number,
/// an unknown column letter, a sphere count other than 0, 1, 2, or a constraint column (`a`, `A`, `b`, `F`, `E`) this
/// inverse does not take.
pub fn parse_rxt(text: &str) -> Result<Vec<Row>, InverseError> {
    if !text.starts_with("IAD1") {
        return Err(InverseError::parse(Some(1), "an .rxt file must begin with IAD1"));
    }
    let lines = clean_lines(&text[4..]);
    let (header, (legend_line, legend), rest, li) = read_header(&lines)?;
    let numeric = legend.len() == 1 && ('1'..='7').contains(&legend.chars().next().unwrap_or(' '));
    let labels: Vec<char> = if numeric { Vec::new() } else { legend.chars().collect() };
    for c in &labels {
        if !"LrtugdnNRTwWcCiSMBDeqa AbFEj".contains(*c) {
            return Err(InverseError::parse(
                Some(legend_line),
                format!("unknown column letter '{c}'"),
            ));
        }
        if "aAbFEj".contains(*c) {
            return Err(InverseError::parse(
                Some(legend_line),
                format!("column '{c}' (a constraint on the answer) is not supported by km fit"),
            ));
        }
    }
    let k = if numeric { legend.parse::<usize>().unwrap_or(2) } else { labels.len() };

    // The template set-up from the header.
    let h = &header;
    let sphere = |o: usize| Sphere {
        d_sphere: h[o],
        d_sample: h[o + 1],
        d_third: h[o + 2],
        d_detector: h[o + 3],
        r_wall: h[o + 4],
        r_detector: 0.0,
    };
    let base = Base {
        n_sample: h[0],
        n_slide: h[1],
        thickness: h[2],
        slide_thickness: h[3],
        r_std: h[5],
        t_std: 1.0,
        count: h[6],
        r_sphere: sphere(7),
        t_sphere: sphere(12),
        c: 1.0,
        c_t: 1.0,
        theta: 0.0,
    };

    // Data values, number by number, with their lines.
    let mut tokens = Vec::new();
    for (no, tok) in &rest {
        tokens.push((*no, number(tok, *no)?));
    }
    for (no, l) in &lines[li..] {
        for tok in l.split_whitespace() {
            tokens.push((*no, number(tok, *no)?));
        }
    }
    let mut rows = Vec::new();
    let mut it = tokens.into_iter().peekable();
    while let Some(&(no, _)) = it.peek() {
        let mut take = || {
            it.next().map(|t| t.1).ok_or_else(|| {
                InverseError::parse(Some(no), "the file ends in the middle of a row")
            })
        };
        let (Read { m_r, m_t, m_u, lambda, g }, b) =
            read_row(&mut take, &base, numeric, k, &labels)?;
        let m_r = m_r.ok_or_else(|| InverseError::parse(Some(no), "row without M_R"))?;
        let reflectance_only = m_t.is_none();
        let m_t = m_t.unwrap_or(0.0);
        // iad treats M_U = 0 as "not measured".
        let m_u = m_u.filter(|&u| u > 0.0);
        let setup = b.setup().map_err(|e| InverseError::parse(Some(no), e.to_string()))?;
        rows.push(Row {
            wavelength_nm: lambda,
            setup,
            measurement: Measurement { m_r, m_t, m_u, sigma_r: None, sigma_t: None, sigma_u: None },
            reflectance_only,
            g,
            notes: unmodelled(h[4], &labels),
        });
    }
    if rows.is_empty() {
        return Err(InverseError::parse(None, "no measurement rows"));
    }
    Ok(rows)
}

/// Notes for what an `.rxt` file gives and the fit does not model: the
/// beam diameter (header or column `B`); the fit compares the measurements
/// with a slab of infinite extent lit by a beam wider than the light's
/// lateral spread. (Lost light, with spheres, is noted by the fit itself.)
fn unmodelled(beam: f64, labels: &[char]) -> Vec<String> {
    let mut notes = Vec::new();
    if beam > 0.0 || labels.contains(&'B') {
        notes.push(
            "the beam diameter of the file is not used: the model is a slab of infinite extent \
             under a beam wider than the light's lateral spread"
                .to_string(),
        );
    }
    notes
}

/// The header's 17 numbers, the legend (its line and text), the tokens that
/// follow the legend on the header's last line (iad's terse form), and the
/// index of the first line after the legend.
type Header = (Vec<f64>, (usize, String), Vec<(usize, String)>, usize);

/// Read the header and legend of an `.rxt` file from its cleaned lines.
fn read_header(lines: &[(usize, String)]) -> Result<Header, InverseError> {
    // Tokens of the header, line by line, until 17 numbers are read. iad
    // reads the file as a stream of tokens, so a "terse" file may carry the
    // legend and the data on the header's last line (iad's `terse_A.rxt`):
    // what follows the 17th number on its line is kept for them.
    let mut header = Vec::with_capacity(17);
    let mut li = 0;
    let mut rest: Vec<(usize, String)> = Vec::new();
    while header.len() < 17 {
        let Some((no, l)) = lines.get(li) else {
            return Err(InverseError::parse(None, "the header ends before its 17 numbers"));
        };
        for tok in l.split_whitespace() {
            if header.len() == 17 {
                rest.push((*no, tok.to_string()));
            } else {
                header.push(number(tok, *no)?);
            }
        }
        li += 1;
    }
    // The legend: the next token on the header's line, else the next line with content.
    let legend = if !rest.is_empty() {
        let (no, tok) = rest.remove(0);
        (no, tok.chars().filter(|c| *c != '-').collect::<String>())
    } else {
        loop {
            let Some((no, l)) = lines.get(li) else {
                return Err(InverseError::parse(None, "no legend line after the header"));
            };
            li += 1;
            let s: String = l.chars().filter(|c| !c.is_whitespace() && *c != '-').collect();
            if !s.is_empty() {
                break (*no, s);
            }
        }
    };
    Ok((header, legend, rest, li))
}

/// What one row gives besides the set-up.
struct Read {
    m_r: Option<f64>,
    m_t: Option<f64>,
    m_u: Option<f64>,
    lambda: Option<f64>,
    g: Option<f64>,
}

/// Read one row with `take` (the next number of the file): by iad's digit
/// legend `k` (`numeric`) or by the column letters `labels`; returns the
/// measured values and the header's set-up with the row's overrides.
fn read_row(
    take: &mut dyn FnMut() -> Result<f64, InverseError>,
    base: &Base,
    numeric: bool,
    k: usize,
    labels: &[char],
) -> Result<(Read, Base), InverseError> {
    let (mut m_r, mut m_t, mut m_u, mut lambda, mut g) = (None, None, None, None, None);
    let mut b = base.clone();
    if numeric {
        // iad's rule: a first value above 1 is the wavelength.
        let first = take()?;
        m_r = Some(if first > 1.0 {
            lambda = Some(first);
            take()?
        } else {
            first
        });
        if k >= 2 {
            m_t = Some(take()?);
        }
        if k >= 3 {
            m_u = Some(take()?);
        }
        if k >= 4 {
            b.r_sphere.r_wall = take()?;
            b.t_sphere.r_wall = b.r_sphere.r_wall;
        }
        if k >= 5 {
            b.t_sphere.r_wall = take()?;
        }
        if k >= 6 {
            b.r_std = take()?;
        }
        if k >= 7 {
            b.t_std = take()?;
        }
    } else {
        let mut w_read = false;
        for &c in labels {
            let x = take()?;
            match c {
                'L' => lambda = Some(x),
                'r' => m_r = Some(x),
                't' => m_t = Some(x),
                'u' => m_u = Some(x),
                'g' => g = Some(x),
                'd' => b.thickness = x,
                'D' => b.slide_thickness = x,
                'n' => b.n_sample = x,
                'N' => b.n_slide = x,
                'R' => b.r_std = x,
                'T' => b.t_std = x,
                'w' => {
                    b.r_sphere.r_wall = x;
                    if !w_read {
                        b.t_sphere.r_wall = x;
                    }
                }
                'W' => {
                    b.t_sphere.r_wall = x;
                    w_read = true;
                }
                'c' => b.c = x,
                'C' => b.c_t = x,
                'i' => b.theta = x,
                'S' | 'M' => b.count = x,
                // Beam diameter, tolerance, quadrature: no effect on this inverse.
                _ => {}
            }
        }
    }
    Ok((Read { m_r, m_t, m_u, lambda, g }, b))
}

/// The header's values, overridable per row.
#[derive(Debug, Clone)]
struct Base {
    n_sample: f64,
    n_slide: f64,
    thickness: f64,
    slide_thickness: f64,
    r_std: f64,
    t_std: f64,
    count: f64,
    r_sphere: Sphere,
    t_sphere: Sphere,
    c: f64,
    c_t: f64,
    theta: f64,
}

impl Base {
    fn setup(&self) -> Result<Setup, InverseError> {
        // iad: a slide of thickness 0 or index 0 or 1 is no slide.
        let n_slide = (self.slide_thickness > 0.0 && self.n_slide > 1.0).then_some(self.n_slide);
        let sample =
            Sample::new(self.thickness, self.n_sample, n_slide)?.with_incidence(self.theta)?;
        let spheres = match self.count {
            0.0 => None,
            1.0 | 2.0 => {
                let s = SphereSetup {
                    count: self.count as usize,
                    r_sphere: self.r_sphere,
                    t_sphere: self.t_sphere,
                    r_std: self.r_std,
                    t_std: self.t_std,
                    baffle: true,
                };
                s.validate()?;
                Some(s)
            }
            n => return Err(InverseError::invalid("spheres", n, "must be 0, 1 or 2")),
        };
        Ok(Setup { sample, specular_in_m_r: self.c, unscattered_in_m_t: self.c_t, spheres })
    }
}

/// The default size limit of a measurement file ([`read_file`]), bytes.
pub const MAX_FILE_BYTES: u64 = 16 << 20;

/// The text of a measurement file (`.rxt`, `.csv`), read through the
/// checked reader of scenes (`km_core::read_checked_text`): a regular file
/// (or `-`), refused before opening otherwise (a FIFO without a writer,
/// `/dev/zero`), opened without blocking, at most [`MAX_FILE_BYTES`]
/// (`KM_MAX_FIT_BYTES` in the environment raises it).
///
/// # Errors
/// [`InverseError::Parse`] with the reader's message.
pub fn read_file(path: &std::path::Path) -> Result<String, InverseError> {
    let max = std::env::var("KM_MAX_FIT_BYTES")
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(MAX_FILE_BYTES);
    km_core::read_checked_text(path, max, "a measurement file", "KM_MAX_FIT_BYTES")
        .map_err(|e| InverseError::parse(None, e.to_string()))
}

fn number(tok: &str, line: usize) -> Result<f64, InverseError> {
    tok.parse::<f64>()
        .ok()
        .filter(|x| x.is_finite())
        .ok_or_else(|| InverseError::parse(Some(line), format!("'{tok}' is not a number")))
}

/// Parse a CSV of spectra for the given sample set-up.
///
/// # Errors
/// [`InverseError::Parse`] for a missing header or column (`m_r`, `m_t`),
/// an unknown column, a bad number or a row of the wrong length.
///
/// ```
/// use km_inverse::{forward::Sample, rxt::parse_csv, slab::Setup};
/// let set = Setup::new(Sample::new(1.0, 1.4, None).unwrap());
/// let rows = parse_csv("wavelength_nm,m_r,m_t\n500,0.3,0.4\n", &set).unwrap();
/// assert_eq!(rows[0].wavelength_nm, Some(500.0));
/// ```
pub fn parse_csv(text: &str, setup: &Setup) -> Result<Vec<Row>, InverseError> {
    // A byte order mark (spreadsheets write one) is not part of the header.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = clean_lines(text).into_iter().filter(|(_, l)| !l.trim().is_empty());
    let Some((hno, head)) = lines.next() else {
        return Err(InverseError::parse(None, "empty CSV"));
    };
    let names: Vec<String> = head.split(',').map(|s| s.trim().to_lowercase()).collect();
    const KNOWN: [&str; 8] =
        ["wavelength_nm", "m_r", "m_t", "m_u", "sigma_r", "sigma_t", "sigma_u", "g"];
    for (i, n) in names.iter().enumerate() {
        if !KNOWN.contains(&n.as_str()) {
            return Err(InverseError::parse(
                Some(hno),
                format!("unknown column '{n}' (known: {})", KNOWN.join(", ")),
            ));
        }
        if names[..i].contains(n) {
            return Err(InverseError::parse(Some(hno), format!("column '{n}' appears twice")));
        }
    }
    let col = |n: &str| names.iter().position(|x| x == n);
    let (Some(ir), Some(it)) = (col("m_r"), col("m_t")) else {
        return Err(InverseError::parse(Some(hno), "the header needs columns m_r and m_t"));
    };
    let mut rows = Vec::new();
    for (no, l) in lines {
        let vals: Vec<f64> =
            l.split(',').map(|t| number(t.trim(), no)).collect::<Result<_, _>>()?;
        if vals.len() != names.len() {
            return Err(InverseError::parse(
                Some(no),
                format!("{} values for {} columns", vals.len(), names.len()),
            ));
        }
        let get = |n: &str| col(n).map(|i| vals[i]);
        if let Some(w) = get("wavelength_nm")
            && w <= 0.0
        {
            return Err(InverseError::parse(
                Some(no),
                format!("wavelength_nm = {w}: a wavelength must be > 0"),
            ));
        }
        rows.push(Row {
            wavelength_nm: get("wavelength_nm"),
            setup: *setup,
            measurement: Measurement {
                m_r: vals[ir],
                m_t: vals[it],
                m_u: get("m_u"),
                sigma_r: get("sigma_r"),
                sigma_t: get("sigma_t"),
                sigma_u: get("sigma_u"),
            },
            reflectance_only: false,
            g: get("g"),
            notes: Vec::new(),
        });
    }
    if rows.is_empty() {
        return Err(InverseError::parse(None, "no measurement rows"));
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// iad's `tests/rxt/1_sphere/terse_A.rxt` puts the header, the legend
    /// and two rows on one line; it reads as the same file written out.
    #[test]
    fn terse_file_reads_as_the_written_out_one() {
        let terse = "IAD1 1.34 1.5 1 1 5 .96 1 203.2 25.4 12.7 1 .96 203.2 25.4 12.7 1 .96 2 \
                     0.168 0.249 0.162 0.264";
        let long = "IAD1\n1.34 1.5 1 1 5 .96 1\n203.2 25.4 12.7 1 .96\n203.2 25.4 12.7 1 .96\n\
                    2\n0.168 0.249\n0.162 0.264\n";
        let (a, b) = (parse_rxt(terse).unwrap(), parse_rxt(long).unwrap());
        assert_eq!(a.len(), 2);
        assert_eq!(a, b);
        assert_eq!(a[1].measurement.m_t, 0.264);
        // A row cut short is still refused, naming the line.
        let cut = "IAD1 1.34 1.5 1 1 5 .96 1 203.2 25.4 12.7 1 .96 203.2 25.4 12.7 1 .96 2 0.168";
        assert!(parse_rxt(cut).unwrap_err().to_string().contains("line 1"));
    }
}
