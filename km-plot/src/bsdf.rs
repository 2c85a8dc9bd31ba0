//! Pictures of a BSDF table (`km bsdf --plot`): in-plane polar plots of the
//! BRDF and BTDF for several incidence angles, and a (theta_o, phi) heat map
//! of the BRDF (and BTDF) per chosen incidence angle, with the charts of
//! [`crate::chart`].

use std::path::{Path, PathBuf};

use anyhow::Context;

use km::bsdf::Bsdf;

use crate::chart::{HeatMap, PolarChart, PolarCurve, PolarSpike, plane_angle, write_chart};

/// Indices of the table's incidence angles nearest to 0, 30, 60 and 75
/// degrees (each once).
pub fn chosen_incidences(b: &Bsdf) -> Vec<usize> {
    let mut out: Vec<usize> = Vec::new();
    for target in [0.0, 30.0, 60.0, 75.0] {
        let i = (0..b.theta_i.len())
            .min_by(|&x, &y| {
                (b.theta_i[x] - target).abs().total_cmp(&(b.theta_i[y] - target).abs())
            })
            .unwrap_or(0);
        if !out.contains(&i) {
            out.push(i);
        }
    }
    out
}

/// The exit angles in ascending order (indices into `theta_o`).
fn sorted_exits(b: &Bsdf) -> Vec<usize> {
    let mut o: Vec<usize> = (0..b.theta_o.len()).collect();
    o.sort_by(|&x, &y| b.theta_o[x].total_cmp(&b.theta_o[y]));
    o
}

/// The in-plane polar plot of channel `c`: one curve per chosen incidence,
/// BRDF above the surface, BTDF below (azimuth 180 on the mirror side,
/// 0 back towards the source), the mirror reflection as a spike.
pub fn polar(b: &Bsdf, c: usize) -> PolarChart {
    let exits = sorted_exits(b);
    let mut curves = Vec::new();
    let mut spikes = Vec::new();
    let label = if b.channels.len() > 1 {
        b.labels.get(c).cloned().unwrap_or_default()
    } else {
        String::new()
    };
    for (k, &i) in chosen_incidences(b).iter().enumerate() {
        let ti = b.theta_i[i];
        for transmitted in [false, true] {
            if transmitted && !b.transmits {
                continue;
            }
            let mut pts = Vec::new();
            // Back side (azimuth 0), from grazing to the normal, then the mirror side.
            for &o in exits.iter().rev() {
                let v = if transmitted { b.btdf(c, i, o, 0.0) } else { b.brdf(c, i, o, 0.0) };
                pts.push((plane_angle(b.theta_o[o], !transmitted, false), v.max(0.0)));
            }
            for &o in &exits {
                let v = if transmitted { b.btdf(c, i, o, 180.0) } else { b.brdf(c, i, o, 180.0) };
                pts.push((plane_angle(b.theta_o[o], !transmitted, true), v.max(0.0)));
            }
            curves.push(PolarCurve {
                label: format!("{} θi = {:.0}°", if transmitted { "BTDF" } else { "BRDF" }, ti),
                points: pts,
                colour: k,
                dashed: transmitted,
            });
        }
        let spec = b.channels[c].reflectance_specular[i];
        if spec > 0.0 && k == 0 {
            spikes.push(PolarSpike {
                psi_deg: plane_angle(ti, true, true),
                length: 0.0,
                label: format!("mirror {spec:.3} (θi {ti:.0}°)"),
            });
        }
    }
    // A spike's length in the radial units: a fixed fraction of the largest curve value.
    let top = curves.iter().flat_map(|c| c.points.iter().map(|p| p.1)).fold(0.0f64, f64::max);
    for s in &mut spikes {
        s.length = 0.8 * top;
    }
    PolarChart {
        title: format!(
            "In-plane BRDF{} {}(light from the left, mirror side right)",
            if b.transmits { " / BTDF (dashed)" } else { "" },
            if label.is_empty() { String::new() } else { format!("[{label}] ") }
        ),
        incidence_deg: chosen_incidences(b).first().map(|&i| b.theta_i[i]),
        curves,
        spikes,
        r_label: "1/sr".into(),
        surface: true,
    }
}

/// Heat map of channel `c` at incidence `i` over (phi, theta_o), BRDF or BTDF,
/// on the azimuths `phi` (degrees).
pub fn heat_map(b: &Bsdf, c: usize, i: usize, transmitted: bool, phi: &[f64]) -> HeatMap {
    let exits = sorted_exits(b);
    let mut z = Vec::with_capacity(exits.len());
    let mut buf = vec![0.0; phi.len()];
    for &o in &exits {
        b.eval_into(c, i, o, phi, transmitted, &mut buf);
        z.push(buf.iter().map(|v| Some(*v)).collect());
    }
    let label = if b.channels.len() > 1 {
        b.labels.get(c).cloned().unwrap_or_default()
    } else {
        String::new()
    };
    HeatMap {
        title: format!(
            "{} at θi = {:.1}°{} (mirror side at φ = 180°)",
            if transmitted { "BTDF" } else { "BRDF" },
            b.theta_i[i],
            if label.is_empty() { String::new() } else { format!(" [{label}]") }
        ),
        x_label: "azimuth φ (deg)".into(),
        y_label: "exit angle θo (deg)".into(),
        x: phi.to_vec(),
        // Row centres rounded for the tick labels (Gauss angles have many digits).
        y: exits.iter().map(|&o| (b.theta_o[o] * 10.0).round() / 10.0).collect(),
        x_log: false,
        z,
        z_label: if transmitted { "BTDF (1/sr)".into() } else { "BRDF (1/sr)".into() },
        z_log: false,
        z_floor: 0.0,
        ..Default::default()
    }
}

/// Write every picture of `km bsdf --plot` into `dir`: `bsdf-polar-C` per
/// channel and `bsdf-brdf-C-iK` / `bsdf-btdf-C-iK` heat maps for the chosen
/// incidence angles (PNG and SVG each), `C` the channel's name
/// ([`channel_names`]). Returns the paths written.
///
/// # Errors
/// Drawing or file errors.
pub fn write_all(b: &Bsdf, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    let phi: Vec<f64> = (0..72).map(|k| 2.5 + 5.0 * k as f64).collect();
    let names = channel_names(b);
    for (c, name) in names.iter().enumerate() {
        out.extend(write_chart(dir, &format!("bsdf-polar-{name}"), &polar(b, c))?);
        for i in chosen_incidences(b) {
            let t = b.theta_i[i].round() as i64;
            let chart = heat_map(b, c, i, false, &phi);
            out.extend(write_chart(dir, &format!("bsdf-brdf-{name}-i{t}"), &chart)?);
            if b.transmits {
                let chart = heat_map(b, c, i, true, &phi);
                out.extend(write_chart(dir, &format!("bsdf-btdf-{name}-i{t}"), &chart)?);
            }
        }
    }
    Ok(out)
}

/// The channels' names in file names: their labels (`R`, `G`, `B`, `450nm`
/// for "450 nm", `0` for a lone channel) with spaces dropped and any
/// character but letters, digits, `.`, `-`, `_` replaced by `_`; the channel
/// index appended (`-c`) where two names would be equal, and the index
/// alone for an empty label.
pub fn channel_names(b: &Bsdf) -> Vec<String> {
    let clean = |c: usize| -> String {
        let l = b.labels.get(c).map_or(String::new(), |l| {
            l.chars()
                .filter(|ch| !ch.is_whitespace())
                .map(|ch| if ch.is_ascii_alphanumeric() || "._-".contains(ch) { ch } else { '_' })
                .collect()
        });
        if l.is_empty() { c.to_string() } else { l }
    };
    let names: Vec<String> = (0..b.channels.len()).map(clean).collect();
    names
        .iter()
        .enumerate()
        .map(|(c, n)| {
            if names.iter().filter(|m| *m == n).count() > 1 {
                format!("{n}-{c}")
            } else {
                n.clone()
            }
        })
        .collect()
}

/// The pictures of a computed BSDF file (`km bsdf --plot`) into `dir`
/// (created if absent): the table's incidence angles nearest to 0, 30, 60,
/// 75 degrees ([`chosen_incidences`]), recomputed on exit angles every
/// degree so that the curves are smooth whatever the table's grid, drawn by
/// [`write_all`]. Returns the paths written.
///
/// # Errors
/// The directory, the BSDF's computation, drawing or file errors.
pub fn write_file_plots(
    file: &km::bsdf_file::BsdfFile,
    scene: &km::Scene,
    dir: &Path,
) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let picks: Vec<f64> =
        chosen_incidences(&file.bsdf).into_iter().map(|i| file.bsdf.theta_i[i]).collect();
    let dense: Vec<f64> = (0..90).map(f64::from).collect();
    write_all(&Bsdf::new(scene, &picks, &dense, &file.options)?, dir)
}
