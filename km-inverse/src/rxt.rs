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

/// Strip `#` comments; the lines with their 1-based numbers, one by one
/// (nothing is copied: a file's memory is its text and its rows).
fn clean_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines().enumerate().map(|(i, l)| (i + 1, l.split('#').next().unwrap_or("")))
}

/// The default row budget of a measurement file, or of one request of fits
/// (`docs/limits.md` §1): one row's fit takes about 0.5 ms, so 10^4 rows
/// are about 5 s.
pub const MAX_ROWS: usize = 10_000;

/// The row budget at a budget factor (`--budget F`, Python `budget=`):
/// [`MAX_ROWS`] times the factor, at least one row.
#[must_use]
pub fn max_rows(factor: f64) -> usize {
    // `as` saturates: a huge factor is no limit.
    ((MAX_ROWS as f64 * factor).ceil() as usize).max(1)
}

/// The refusal of more rows than the budget allows; `raise` says how to
/// raise it (the flag or keyword of the caller), appended after `; `.
#[must_use]
pub fn too_many_rows(rows: usize, more: bool, max: usize, raise: &str) -> InverseError {
    let or_more = if more { " or more" } else { "" };
    let raise = if raise.is_empty() { String::new() } else { format!("; {raise}") };
    InverseError::parse(
        None,
        format!(
            "{rows}{or_more} measurement rows, over the budget of {max} rows a request (about \
             0.5 ms of fitting a row){raise}"
        ),
    )
}

/// Parse an iad `.rxt` file, without a row budget (see [`parse_rxt_within`]).
///
/// # Errors
/// As [`parse_rxt_within`].
pub fn parse_rxt(text: &str) -> Result<Vec<Row>, InverseError> {
    parse_rxt_within(text, usize::MAX, "")
}

/// Parse an iad `.rxt` file of at most `max_rows` rows: the rows are
/// counted as they are read and the file is refused at the first row past
/// the budget (then only counted on, not kept), so its memory stays bounded.
///
/// # Errors
/// [`too_many_rows`] (with `raise`) past `max_rows`;
/// [`InverseError::Parse`] with the line for a missing magic, a bad number,
/// an unknown column letter, a sphere count other than 0, 1, 2, or a constraint column (`a`, `A`, `b`, `F`, `E`) this
/// inverse does not take.
pub fn parse_rxt_within(
    text: &str,
    max_rows: usize,
    raise: &str,
) -> Result<Vec<Row>, InverseError> {
    if !text.starts_with("IAD1") {
        return Err(InverseError::parse(Some(1), "an .rxt file must begin with IAD1"));
    }
    let mut lines = clean_lines(&text[4..]);
    let (header, (legend_line, legend), rest) = read_header(&mut lines)?;
    let numeric = legend.len() == 1 && ('1'..='7').contains(&legend.chars().next().unwrap_or(' '));
    let labels: Vec<char> = if numeric { Vec::new() } else { legend.chars().collect() };
    check_labels(&labels, legend_line)?;
    let k = if numeric { legend.parse::<usize>().unwrap_or(2) } else { labels.len() };

    let h = &header;
    let base = header_base(h);

    // Data values, number by number, with their lines, read as needed.
    let data = lines.flat_map(|(no, l)| l.split_whitespace().map(move |t| (no, t)));
    let mut it =
        rest.into_iter().chain(data).map(|(no, t)| number(t, no).map(|x| (no, x))).peekable();
    let mut rows = Vec::new();
    let mut counted = 0usize;
    loop {
        let no = match it.peek() {
            None => break,
            Some(&Ok((no, _))) => no,
            Some(Err(_)) if counted >= max_rows => {
                return Err(too_many_rows(counted, true, max_rows, raise));
            }
            Some(Err(e)) => return Err(e.clone()),
        };
        let mut take = || match it.next() {
            Some(t) => t.map(|t| t.1),
            None => Err(InverseError::parse(Some(no), "the file ends in the middle of a row")),
        };
        let read = read_row(&mut take, &base, numeric, k, &labels);
        if counted >= max_rows {
            // Past the budget: count the rest (to name it), keep nothing.
            match read {
                Ok(_) => counted += 1,
                Err(_) => return Err(too_many_rows(counted, true, max_rows, raise)),
            }
            continue;
        }
        let (Read { m_r, m_t, m_u, lambda, g }, b) = read?;
        counted += 1;
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
    if counted > max_rows {
        return Err(too_many_rows(counted, false, max_rows, raise));
    }
    if rows.is_empty() {
        return Err(InverseError::parse(None, "no measurement rows"));
    }
    Ok(rows)
}

/// Refuses a column letter of the legend (line `legend_line`) that is
/// unknown or a constraint on the answer.
fn check_labels(labels: &[char], legend_line: usize) -> Result<(), InverseError> {
    for c in labels {
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
    Ok(())
}

/// The template set-up from the header's numbers `h`.
fn header_base(h: &[f64]) -> Base {
    let sphere = |o: usize| Sphere {
        d_sphere: h[o],
        d_sample: h[o + 1],
        d_third: h[o + 2],
        d_detector: h[o + 3],
        r_wall: h[o + 4],
        r_detector: 0.0,
    };
    Base {
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
    }
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

/// The header's 17 numbers, the legend (its line and text), and the tokens
/// that follow the legend on the header's last line (iad's terse form);
/// `lines` is left at the first line after the legend.
type Header<'a> = (Vec<f64>, (usize, String), Vec<(usize, &'a str)>);

/// Read the header and legend of an `.rxt` file from its cleaned lines.
fn read_header<'a>(
    lines: &mut dyn Iterator<Item = (usize, &'a str)>,
) -> Result<Header<'a>, InverseError> {
    // Tokens of the header, line by line, until 17 numbers are read. iad
    // reads the file as a stream of tokens, so a "terse" file may carry the
    // legend and the data on the header's last line (iad's `terse_A.rxt`):
    // what follows the 17th number on its line is kept for them.
    let mut header = Vec::with_capacity(17);
    let mut rest: Vec<(usize, &str)> = Vec::new();
    while header.len() < 17 {
        let Some((no, l)) = lines.next() else {
            return Err(InverseError::parse(None, "the header ends before its 17 numbers"));
        };
        for tok in l.split_whitespace() {
            if header.len() == 17 {
                rest.push((no, tok));
            } else {
                header.push(number(tok, no)?);
            }
        }
    }
    // The legend: the next token on the header's line, else the next line with content.
    let legend = if !rest.is_empty() {
        let (no, tok) = rest.remove(0);
        (no, tok.chars().filter(|c| *c != '-').collect::<String>())
    } else {
        loop {
            let Some((no, l)) = lines.next() else {
                return Err(InverseError::parse(None, "no legend line after the header"));
            };
            let s: String = l.chars().filter(|c| !c.is_whitespace() && *c != '-').collect();
            if !s.is_empty() {
                break (no, s);
            }
        }
    };
    Ok((header, legend, rest))
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

/// Parse a CSV of spectra for the given sample set-up, without a row
/// budget (see [`parse_csv_within`]).
///
/// # Errors
/// As [`parse_csv_within`].
///
/// ```
/// use km_inverse::{forward::Sample, rxt::parse_csv, slab::Setup};
/// let set = Setup::new(Sample::new(1.0, 1.4, None).unwrap());
/// let rows = parse_csv("wavelength_nm,m_r,m_t\n500,0.3,0.4\n", &set).unwrap();
/// assert_eq!(rows[0].wavelength_nm, Some(500.0));
/// ```
pub fn parse_csv(text: &str, setup: &Setup) -> Result<Vec<Row>, InverseError> {
    parse_csv_within(text, setup, usize::MAX, "")
}

/// Parse a CSV of spectra of at most `max_rows` rows for the given sample
/// set-up: the file is refused at the first row past the budget (the
/// remaining lines are then only counted), so its memory stays bounded.
///
/// # Errors
/// [`too_many_rows`] (with `raise`) past `max_rows`;
/// [`InverseError::Parse`] for a missing header or column (`m_r`, `m_t`),
/// an unknown column, a bad number or a row of the wrong length.
///
pub fn parse_csv_within(
    text: &str,
    setup: &Setup,
    max_rows: usize,
    raise: &str,
) -> Result<Vec<Row>, InverseError> {
    // A byte order mark (spreadsheets write one) is not part of the header.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = clean_lines(text).filter(|(_, l)| !l.trim().is_empty());
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
    while let Some((no, l)) = lines.next() {
        if rows.len() == max_rows {
            let count = max_rows + 1 + lines.count();
            return Err(too_many_rows(count, false, max_rows, raise));
        }
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

    /// The row budget counts the rows of either format as it reads them:
    /// a file of exactly the budget is read whole, one row more is refused
    /// naming the count and the way to raise it (the count of the CSV's
    /// lines, and of the `.rxt` rows read on past the budget).
    #[test]
    fn files_over_the_row_budget_are_refused_with_their_count() {
        let set = Setup::new(Sample::new(1.0, 1.4, None).unwrap());
        let csv = |n: usize| format!("wavelength_nm,m_r,m_t\n{}", "400,.2,.3\n".repeat(n));
        assert_eq!(parse_csv_within(&csv(5), &set, 5, "raise it").unwrap().len(), 5);
        let e = parse_csv_within(&csv(9), &set, 5, "raise it with --budget").unwrap_err();
        let m = e.to_string();
        assert!(m.contains("9 measurement rows") && m.contains("budget of 5 rows"), "{m}");
        assert!(m.ends_with("; raise it with --budget"), "{m}");
        let rxt = |n: usize| {
            format!(
                "IAD1 1.4 1.5 1 1 5 1 0 200 25 12 1 .96 200 25 12 1 .96\n2\n{}",
                "500 .2 .3\n".repeat(n)
            )
        };
        assert_eq!(parse_rxt_within(&rxt(5), 5, "").unwrap().len(), 5);
        let m = parse_rxt_within(&rxt(7), 5, "x").unwrap_err().to_string();
        assert!(m.contains("7 measurement rows") && m.contains("budget of 5 rows"), "{m}");
        // Without a budget the same files are read whole.
        assert_eq!(parse_rxt(&rxt(7)).unwrap().len(), 7);
        assert_eq!(parse_csv(&csv(9), &set).unwrap().len(), 9);
        assert_eq!(max_rows(1.0), MAX_ROWS);
        assert_eq!(max_rows(2.5), 25_000);
        assert_eq!(max_rows(1e-9), 1);
    }

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
