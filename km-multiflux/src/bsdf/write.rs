//! Files of a BSDF table: `npz` (numpy), `csv` (long format) and `fourier`
//! (the layerlab / Mitsuba 0.6 / pbrt-v3 Fourier BSDF file), all written
//! atomically (`docs/bsdf.md` §3).

use std::io::Write;
use std::path::Path;

use super::{Bsdf, BsdfError};

/// Write `bytes` to `path` atomically: a temporary file in the same
/// directory, then a rename. Refuses to replace anything but a regular file.
///
/// # Errors
/// [`BsdfError::Io`] on any failure, [`BsdfError::Input`] if `path` names a
/// directory, a device, a pipe or a symbolic link.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), BsdfError> {
    let io = |source| BsdfError::Io { path: path.display().to_string(), source };
    if let Ok(meta) = std::fs::symlink_metadata(path)
        && !meta.file_type().is_file()
    {
        return Err(BsdfError::Input {
            name: "out",
            reason: format!("{} exists and is not a regular file", path.display()),
        });
    }
    let name = path.file_name().ok_or_else(|| BsdfError::Input {
        name: "out",
        reason: format!("{} has no file name", path.display()),
    })?;
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let tmp = dir.join(format!(".{}.{}.tmp", name.to_string_lossy(), std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(io)
}

/// CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320), as zip requires.
fn crc32(data: &[u8]) -> u32 {
    let mut table = [0u32; 256];
    for (n, t) in table.iter_mut().enumerate() {
        let mut c = n as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
        }
        *t = c;
    }
    let mut c = 0xFFFF_FFFFu32;
    for &b in data {
        c = table[((c ^ b as u32) & 0xFF) as usize] ^ (c >> 8);
    }
    c ^ 0xFFFF_FFFF
}

/// A zip archive of stored (uncompressed) entries (PKWARE APPNOTE 6.3, §4.3):
/// local headers, data, central directory, end record. Entries must stay
/// below 4 GiB (no zip64); the caller bounds the table size.
pub fn zip_stored(entries: &[(String, Vec<u8>)]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut central = Vec::new();
    for (name, data) in entries {
        let offset = out.len() as u32;
        let crc = crc32(data);
        let size = data.len() as u32;
        // Local file header.
        out.extend_from_slice(&0x0403_4b50u32.to_le_bytes());
        out.extend_from_slice(&20u16.to_le_bytes()); // version needed
        out.extend_from_slice(&0u16.to_le_bytes()); // flags
        out.extend_from_slice(&0u16.to_le_bytes()); // method: stored
        out.extend_from_slice(&0u16.to_le_bytes()); // time
        out.extend_from_slice(&0x21u16.to_le_bytes()); // date: 1980-01-01
        out.extend_from_slice(&crc.to_le_bytes());
        out.extend_from_slice(&size.to_le_bytes());
        out.extend_from_slice(&size.to_le_bytes());
        out.extend_from_slice(&(name.len() as u16).to_le_bytes());
        out.extend_from_slice(&0u16.to_le_bytes());
        out.extend_from_slice(name.as_bytes());
        out.extend_from_slice(data);
        // Central directory record.
        central.extend_from_slice(&0x0201_4b50u32.to_le_bytes());
        central.extend_from_slice(&20u16.to_le_bytes()); // made by
        central.extend_from_slice(&20u16.to_le_bytes()); // needed
        central.extend_from_slice(&0u16.to_le_bytes());
        central.extend_from_slice(&0u16.to_le_bytes());
        central.extend_from_slice(&0u16.to_le_bytes());
        central.extend_from_slice(&0x21u16.to_le_bytes());
        central.extend_from_slice(&crc.to_le_bytes());
        central.extend_from_slice(&size.to_le_bytes());
        central.extend_from_slice(&size.to_le_bytes());
        central.extend_from_slice(&(name.len() as u16).to_le_bytes());
        central.extend_from_slice(&[0u8; 8]); // extra, comment, disk, internal attrs
        central.extend_from_slice(&0u32.to_le_bytes()); // external attrs
        central.extend_from_slice(&offset.to_le_bytes());
        central.extend_from_slice(name.as_bytes());
    }
    let cd_offset = out.len() as u32;
    let cd_size = central.len() as u32;
    out.extend_from_slice(&central);
    out.extend_from_slice(&0x0605_4b50u32.to_le_bytes());
    out.extend_from_slice(&[0u8; 4]); // disk numbers
    out.extend_from_slice(&(entries.len() as u16).to_le_bytes());
    out.extend_from_slice(&(entries.len() as u16).to_le_bytes());
    out.extend_from_slice(&cd_size.to_le_bytes());
    out.extend_from_slice(&cd_offset.to_le_bytes());
    out.extend_from_slice(&0u16.to_le_bytes());
    out
}

/// An `.npy` file (format version 1.0): magic, header dict padded to a
/// multiple of 64 bytes, then the data in C order.
pub fn npy(descr: &str, shape: &[usize], data: &[u8]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let shape = match dims.len() {
        0 => "()".to_string(),
        1 => format!("({},)", dims[0]),
        _ => format!("({})", dims.join(", ")),
    };
    let mut header = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    // 10 bytes of preamble + header + '\n', padded with spaces to 64.
    let total = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - total % 64) % 64));
    header.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    out.extend_from_slice(data);
    out
}

fn f64_bytes(v: &[f64]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// A table of a BSDF at the azimuths `phi` with everything the files carry.
pub struct Table<'a> {
    /// The BSDF (its polar grids and totals).
    pub bsdf: &'a Bsdf,
    /// Azimuths, degrees (180 = mirror side).
    pub phi: Vec<f64>,
    /// `[((c * n_i + i) * n_o + o) * n_phi + p]`, 1/sr.
    pub brdf: Vec<f64>,
    /// The same for the BTDF (zeros when opaque).
    pub btdf: Vec<f64>,
}

impl<'a> Table<'a> {
    /// Evaluate `bsdf` at every azimuth of `phi` (degrees, finite).
    ///
    /// # Errors
    /// [`BsdfError::Input`] for an empty or non-finite azimuth list, or a
    /// table beyond 2^28 values.
    pub fn new(bsdf: &'a Bsdf, phi: &[f64]) -> Result<Table<'a>, BsdfError> {
        if phi.is_empty() || phi.iter().any(|p| !p.is_finite()) || phi.len() > 100_000 {
            return Err(BsdfError::Input {
                name: "phi",
                reason: "needs 1..=100000 finite azimuths (degrees)".into(),
            });
        }
        let size = bsdf.channels.len() * bsdf.theta_i.len() * bsdf.theta_o.len() * phi.len();
        if size > 1 << 28 {
            return Err(BsdfError::Input {
                name: "grid",
                reason: format!("{size} values per table (at most 2^28)"),
            });
        }
        let (brdf, btdf) = bsdf.table(phi);
        Ok(Table { bsdf, phi: phi.to_vec(), brdf, btdf })
    }

    /// The `npz` file: `theta_i`, `theta_o`, `phi` (degrees), `brdf`, `btdf`
    /// (1/sr, channels x theta_i x theta_o x phi), `reflectance`,
    /// `transmittance`, `reflectance_specular`, `transmittance_direct`
    /// (channels x theta_i), `meta` (a JSON string, numpy unicode scalar).
    pub fn npz(&self, meta: &str) -> Vec<u8> {
        let b = self.bsdf;
        let (nc, ni, no, np) = (b.channels.len(), b.theta_i.len(), b.theta_o.len(), self.phi.len());
        let per_i = |f: &dyn Fn(&super::ChannelBsdf) -> &Vec<f64>| -> Vec<f64> {
            b.channels.iter().flat_map(|c| f(c).iter().copied()).collect()
        };
        let meta_utf32: Vec<u8> = meta.chars().flat_map(|c| (c as u32).to_le_bytes()).collect();
        let nchar = meta.chars().count().max(1);
        let mut meta_data = meta_utf32;
        meta_data.resize(4 * nchar, 0);
        let entries = vec![
            ("theta_i.npy".into(), npy("<f8", &[ni], &f64_bytes(&b.theta_i))),
            ("theta_o.npy".into(), npy("<f8", &[no], &f64_bytes(&b.theta_o))),
            ("phi.npy".into(), npy("<f8", &[np], &f64_bytes(&self.phi))),
            ("brdf.npy".into(), npy("<f8", &[nc, ni, no, np], &f64_bytes(&self.brdf))),
            ("btdf.npy".into(), npy("<f8", &[nc, ni, no, np], &f64_bytes(&self.btdf))),
            (
                "reflectance.npy".into(),
                npy("<f8", &[nc, ni], &f64_bytes(&per_i(&|c| &c.reflectance))),
            ),
            (
                "transmittance.npy".into(),
                npy("<f8", &[nc, ni], &f64_bytes(&per_i(&|c| &c.transmittance))),
            ),
            (
                "reflectance_specular.npy".into(),
                npy("<f8", &[nc, ni], &f64_bytes(&per_i(&|c| &c.reflectance_specular))),
            ),
            (
                "transmittance_direct.npy".into(),
                npy("<f8", &[nc, ni], &f64_bytes(&per_i(&|c| &c.transmittance_direct))),
            ),
            ("meta.npy".into(), npy(&format!("<U{nchar}"), &[], &meta_data)),
        ];
        zip_stored(&entries)
    }

    /// The `csv` file, long format: a header line, then one row per
    /// (channel, theta_i, theta_o, phi):
    /// `channel,theta_i_deg,theta_o_deg,phi_deg,brdf,btdf` (1/sr; full precision).
    pub fn csv(&self) -> Vec<u8> {
        let b = self.bsdf;
        let (ni, no, np) = (b.theta_i.len(), b.theta_o.len(), self.phi.len());
        let mut s = String::from("channel,theta_i_deg,theta_o_deg,phi_deg,brdf,btdf\n");
        for c in 0..b.channels.len() {
            let label = csv_label(b.labels.get(c).cloned().unwrap_or_else(|| c.to_string()));
            for i in 0..ni {
                for o in 0..no {
                    for p in 0..np {
                        let k = ((c * ni + i) * no + o) * np + p;
                        s.push_str(&format!(
                            "{label},{},{},{},{:e},{:e}\n",
                            b.theta_i[i], b.theta_o[o], self.phi[p], self.brdf[k], self.btdf[k]
                        ));
                    }
                }
            }
        }
        s.into_bytes()
    }
}

impl Table<'_> {
    /// The totals file beside the `csv`: a header line, then one row per
    /// (channel, theta_i): `channel,theta_i_deg,reflectance,
    /// reflectance_specular,transmittance,transmittance_direct` (totals with
    /// their delta parts, as the npz's arrays of those names; full precision).
    pub fn totals_csv(&self) -> Vec<u8> {
        let b = self.bsdf;
        let mut s = String::from(
            "channel,theta_i_deg,reflectance,reflectance_specular,transmittance,\
             transmittance_direct\n",
        );
        for (c, ch) in b.channels.iter().enumerate() {
            let label = csv_label(b.labels.get(c).cloned().unwrap_or_else(|| c.to_string()));
            for (i, t) in b.theta_i.iter().enumerate() {
                s.push_str(&format!(
                    "{label},{t},{:e},{:e},{:e},{:e}\n",
                    ch.reflectance[i],
                    ch.reflectance_specular[i],
                    ch.transmittance[i],
                    ch.transmittance_direct[i]
                ));
            }
        }
        s.into_bytes()
    }
}

/// A channel label as a CSV field (quoted when it holds a comma, quote or newline).
fn csv_label(label: String) -> String {
    if label.contains([',', '"', '\n']) {
        format!("\"{}\"", label.replace('"', "\"\""))
    } else {
        label
    }
}

/// Fourier coefficients `a_k` (`k < kmax`) of a real even function of
/// `x = phi - 180 deg` sampled at `x_j = 2 pi j / p`, with the table
/// `cos_t[k * p + j] = cos(k x_j)`: `a_0 = mean`, `a_k = 2/p sum_j f_j cos(k x_j)`
/// (exact for a cosine series of order below `p/2`).
fn cosine_coefficients(f: &[f64], kmax: usize, cos_t: &[f64]) -> Vec<f64> {
    let p = f.len();
    (0..kmax)
        .map(|k| {
            let row = &cos_t[k * p..(k + 1) * p];
            let s: f64 = f.iter().zip(row).map(|(v, c)| v * c).sum();
            if k == 0 { s / p as f64 } else { 2.0 * s / p as f64 }
        })
        .collect()
}

/// pbrt-v3's `IntegrateCatmullRom`: the cumulative integral of the
/// Catmull–Rom spline through `(x, f)` (finite-difference end derivatives).
fn integrate_catmull_rom(x: &[f64], f: &[f64]) -> Vec<f64> {
    let n = x.len();
    let mut cdf = vec![0.0; n];
    let mut sum = 0.0;
    for i in 0..n - 1 {
        let (x0, x1, f0, f1) = (x[i], x[i + 1], f[i], f[i + 1]);
        let width = x1 - x0;
        let d0 = if i > 0 { width * (f1 - f[i - 1]) / (x1 - x[i - 1]) } else { f1 - f0 };
        let d1 = if i + 2 < n { width * (f[i + 2] - f0) / (x[i + 2] - x0) } else { f1 - f0 };
        sum += ((d0 - d1) / 12.0 + (f0 + f1) * 0.5) * width;
        cdf[i + 1] = sum;
    }
    cdf
}

/// Settings of the Fourier file.
#[derive(Debug, Clone, PartialEq)]
pub struct FourierSettings {
    /// Longest series written per pair (orders beyond are dropped).
    pub max_orders: usize,
    /// A pair's series ends where the sum of the dropped `|a_k|` is below
    /// `tail * |a_0|` (layerlab's sparsity rule).
    pub tail: f64,
    /// Linear RGB from the channels: row `c` is what channel `c` adds to
    /// (R, G, B) per unit value (for a spectrum, the weights of its
    /// wavelengths in the colour of the spectrum). The file then holds Y, R,
    /// B of the mixed channels whatever their count; `None`: one channel as
    /// is, three as RGB.
    pub channel_mix: Option<Vec<[f64; 3]>>,
}

impl Default for FourierSettings {
    fn default() -> Self {
        FourierSettings { max_orders: 64, tail: 1e-5, channel_mix: None }
    }
}

/// The Fourier BSDF file of layerlab (Jakob et al. 2014), read by Mitsuba
/// 0.6's `fourier` plugin and pbrt-v3's `fourier` material: header
/// "SCATFUN" v1, the cosines `mu` (the exit and incidence grid mirrored to
/// `[-1, 1]` with two nodes at 0), the CDF in `mu` for sampling, the
/// (offset, length) table per pair and the coefficients, per pair
/// `a_k = |mu_i| f` (times `eta^-2` / `eta^2` for transmission from above /
/// below, pbrt-v3's `FourierBSDF::f` convention; layout in `docs/bsdf.md`).
///
/// `above` must be computed with `theta_i == theta_o` including 0 degrees;
/// `below` (light from the substrate side, the same grids) when the stack
/// transmits. One channel is written as is; three (RGB) as Y, R, B; any
/// count with [`FourierSettings::channel_mix`] as Y, R, B of the mix.
///
/// # Errors
/// [`BsdfError::Input`] for grids that differ or miss 0 degrees, a channel
/// count other than 1 or 3, or a missing `below` for a transmitting stack.
pub fn fourier(
    above: &Bsdf,
    below: Option<&Bsdf>,
    settings: &FourierSettings,
) -> Result<Vec<u8>, BsdfError> {
    check_fourier(above, below, settings)?;
    let nc = above.channels.len();
    let mix = settings.channel_mix.as_deref();
    let n_out = if mix.is_some() { 3 } else { nc };
    let below = below.filter(|_| above.transmits);
    let (idx, nodes) = fourier_nodes(above);
    let h = idx.len();
    let n_mu = nodes.len();
    // Grid index of node j (None for the two zeros) and its side.
    let grid = |j: usize| -> Option<(usize, bool)> {
        if j < h {
            Some((idx[j], false))
        } else if j >= h + 2 {
            Some((idx[n_mu - 1 - j], true))
        } else {
            None
        }
    };
    let eta = match above.n_out {
        Some(nb) if above.transmits => nb / above.n_in,
        _ => 1.0,
    };
    // Orders: the solver's series, and for the single-scattering correction
    // (not a short cosine series) up to `max_orders`.
    let solver_orders = (0..nc).map(|c| above.orders(c)).max().unwrap_or(1);
    let corrected = above.channels.iter().any(|c| !c.tms.is_empty());
    let kmax =
        if corrected { settings.max_orders.max(solver_orders) } else { solver_orders }.max(1);
    let p = 2 * kmax;
    let cos_t: Vec<f64> = (0..kmax * p)
        .map(|q| (2.0 * std::f64::consts::PI * ((q / p) * (q % p)) as f64 / p as f64).cos())
        .collect();
    let phis: Vec<f64> = (0..p).map(|j| 180.0 + 360.0 * j as f64 / p as f64).collect();
    let mut buf = vec![0.0; p];
    let mut pairs: Vec<Vec<Vec<f64>>> = vec![Vec::new(); n_mu * n_mu]; // [O*nMu+I][channel][k]
    for jo in 0..n_mu {
        for ji in 0..n_mu {
            let (Some((gi, i_up)), Some((go, o_up))) = (grid(ji), grid(jo)) else { continue };
            // muI > 0: light travels up (from below); muO > 0: leaves upward.
            let (table, transmitted) = match (i_up, o_up) {
                (false, true) => (Some(above), false),
                (false, false) => (Some(above), true),
                (true, false) => (below, false),
                (true, true) => (below, true),
            };
            let Some(table) = table else { continue };
            if transmitted && !table.transmits {
                continue;
            }
            let mu_i = nodes[ji].abs();
            let scale = mu_i
                * match (transmitted, i_up) {
                    (true, false) => 1.0 / (eta * eta),
                    (true, true) => eta * eta,
                    _ => 1.0,
                };
            let mut chans = Vec::with_capacity(nc);
            for c in 0..nc {
                table.eval_into(c, gi, go, &phis, transmitted, &mut buf);
                let a: Vec<f64> = cosine_coefficients(&buf, kmax, &cos_t);
                chans.push(a.iter().map(|x| x * scale).collect::<Vec<f64>>());
            }
            pairs[jo * n_mu + ji] = written_channels(chans, mix, n_out, kmax);
        }
    }
    // Series length per pair: the tail rule on the largest channel.
    let lengths = series_lengths(&pairs, kmax, settings.tail);
    Ok(scatfun_bytes(&nodes, &pairs, &lengths, n_out, eta))
}

/// Refuses what [`fourier`] cannot write: grids that differ or miss 0
/// degrees, a channel count other than 1 or 3 without a mix (or a mix of
/// the wrong length), a transmitting stack without `below`.
fn check_fourier(
    above: &Bsdf,
    below: Option<&Bsdf>,
    settings: &FourierSettings,
) -> Result<(), BsdfError> {
    let bad = |reason: &str| BsdfError::Input { name: "fourier", reason: reason.into() };
    if above.theta_i != above.theta_o || !above.theta_i.contains(&0.0) {
        return Err(bad("needs theta_i == theta_o on a grid that contains 0 degrees"));
    }
    let nc = above.channels.len();
    match settings.channel_mix.as_deref() {
        Some(w) if w.len() != nc => {
            return Err(bad(&format!("{} channel weights for {nc} channels", w.len())));
        }
        None if nc != 1 && nc != 3 => {
            return Err(bad(&format!(
                "needs 1 or 3 channels (RGB), or the RGB weights of a spectrum's channels; the \
                 scene has {nc}"
            )));
        }
        _ => {}
    }
    if above.transmits {
        match below {
            Some(b) if b.theta_i == above.theta_i && b.theta_o == above.theta_o => {}
            _ => return Err(bad("a transmitting stack needs the table from below too")),
        }
    }
    Ok(())
}

/// The grid's indices by angle ascending (mu descending), and the nodes:
/// -mu (lower medium), 0, 0, +mu (upper medium), ascending.
fn fourier_nodes(above: &Bsdf) -> (Vec<usize>, Vec<f64>) {
    let mut idx: Vec<usize> = (0..above.theta_o.len()).collect();
    idx.sort_by(|&a, &b| above.theta_o[a].total_cmp(&above.theta_o[b])); // mu descending
    let mu_of = |k: usize| above.theta_o[k].to_radians().cos();
    let mut nodes: Vec<f64> = idx.iter().map(|&k| -mu_of(k)).collect(); // -1 first
    nodes.push(0.0);
    nodes.push(0.0);
    nodes.extend(idx.iter().rev().map(|&k| mu_of(k)));
    (idx, nodes)
}

/// One pair's cosine series per channel as written: mixed to linear RGB by
/// `mix` if given, then as Y, R, B when `n_out` is 3.
fn written_channels(
    mut chans: Vec<Vec<f64>>,
    mix: Option<&[[f64; 3]]>,
    n_out: usize,
    kmax: usize,
) -> Vec<Vec<f64>> {
    let nc = chans.len();
    if let Some(w) = mix {
        // Linear RGB of the channels (a spectrum's colour), then as three.
        chans = (0..3)
            .map(|j| (0..kmax).map(|k| (0..nc).map(|c| w[c][j] * chans[c][k]).sum()).collect())
            .collect();
    }
    if n_out == 3 {
        // Y, R, B as layerlab writes them (Rec. 709 luminance).
        let y: Vec<f64> = (0..kmax)
            .map(|k| 0.212671 * chans[0][k] + 0.715160 * chans[1][k] + 0.072169 * chans[2][k])
            .collect();
        chans = vec![y, chans[0].clone(), chans[2].clone()];
    }
    chans
}

/// The series length of each pair of cosines: the shortest whose dropped
/// tail `sum |a_k|` is within `tail_tol` of `|a_0|`, on the largest channel.
fn series_lengths(pairs: &[Vec<Vec<f64>>], kmax: usize, tail_tol: f64) -> Vec<usize> {
    let mut lengths = vec![0usize; pairs.len()];
    for (k, ch) in pairs.iter().enumerate() {
        let mut len = 0;
        for a in ch {
            let reference = a[0].abs();
            if reference == 0.0 && a.iter().all(|x| *x == 0.0) {
                continue;
            }
            let mut l = kmax;
            let mut tail = 0.0;
            for j in (1..kmax).rev() {
                tail += a[j].abs();
                if tail <= tail_tol * reference.max(f64::MIN_POSITIVE) {
                    l = j;
                } else {
                    break;
                }
            }
            len = len.max(l);
        }
        lengths[k] = len;
    }
    lengths
}

/// The bytes of a Fourier BSDF file (`SCATFUN` version 1, as layerlab and
/// pbrt-v3 read it): header, nodes, the luminance CDFs, offsets and lengths,
/// and the coefficients of each pair (`pairs[o * n_mu + i][channel][k]`).
fn scatfun_bytes(
    nodes: &[f64],
    pairs: &[Vec<Vec<f64>>],
    lengths: &[usize],
    nc: usize,
    eta: f64,
) -> Vec<u8> {
    let n_mu = nodes.len();
    let m_max = lengths.iter().copied().max().unwrap_or(0);
    let n_coeffs: usize = lengths.iter().map(|l| l * nc).sum();
    let mut out = Vec::new();
    out.extend_from_slice(b"SCATFUN\x01");
    for v in [1u32, n_mu as u32, n_coeffs as u32, m_max as u32, nc as u32, 1, 0, 0, 0] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for v in [eta as f32, 0.0, 0.0, 0.0, 0.0] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for &m in nodes {
        out.extend_from_slice(&(m as f32).to_le_bytes());
    }
    // CDF in mu_i per mu_o of the luminance a_0 (IntegrateCatmullRom).
    for jo in 0..n_mu {
        let a0: Vec<f64> =
            (0..n_mu).map(|ji| pairs[jo * n_mu + ji].first().map_or(0.0, |a| a[0])).collect();
        for v in integrate_catmull_rom(nodes, &a0) {
            out.extend_from_slice(&(v as f32).to_le_bytes());
        }
    }
    let mut offset = 0u32;
    for &l in lengths {
        out.extend_from_slice(&offset.to_le_bytes());
        out.extend_from_slice(&(l as u32).to_le_bytes());
        offset += (l * nc) as u32;
    }
    for (k, ch) in pairs.iter().enumerate() {
        for a in ch {
            for x in &a[..lengths[k]] {
                out.extend_from_slice(&(*x as f32).to_le_bytes());
            }
        }
    }
    out
}
