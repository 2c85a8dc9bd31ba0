//! `km phase SCENE`: each layer's phase function at angles, its Legendre
//! moments, `g`, and the Mie efficiencies of particle layers
//! (`km::phase_report`, docs/phase.md §6), as a table, JSON or CSV, and
//! optionally a chart of `p(theta)`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use km::phase_report::{ChannelPhase, NORMALISATION, PhaseOptions, PhaseReport, phase_report};
use km_plot::chart::{LineChart, Mark, Series, write_chart};

use crate::solve::{OutputFormat, SceneArg};
use crate::stdout;

/// The most curves of one chart (the legend stays readable).
const MAX_CURVES: usize = 12;

/// The flags of `km phase`.
#[derive(clap::Args)]
pub struct PhaseArgs {
    #[command(flatten)]
    pub input: SceneArg,
    /// Output format: table, json or csv (one row per value: layer, channel, quantity, key, value).
    #[arg(long, value_enum, default_value = "table")]
    pub format: OutputFormat,
    /// Scattering angles in degrees, in [0, 180]: a list `0,1,5,90` or a range
    /// `START:STOP:STEP` (STOP excluded). Default: every 0.05 below 1, every
    /// 0.25 to 10, every degree to 180 (227 angles).
    #[arg(long, value_name = "SPEC", allow_hyphen_values = true)]
    pub angles: Option<String>,
    /// K: print the Legendre moments chi_0 .. chi_K (default 2N, N the default
    /// multi-flux streams of the scene: the moments its delta-M uses).
    #[arg(long, value_name = "K")]
    pub moments: Option<usize>,
    /// Draw p(theta) of every scattering layer and channel into FILE.svg and FILE.png.
    #[arg(long, value_name = "FILE.svg")]
    pub plot: Option<PathBuf>,
    /// Also write the JSON report to this file (atomically; never over the scene).
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

/// Run `km phase`.
pub fn run(args: &PhaseArgs) -> Result<()> {
    let scene = args.input.load()?;
    let angles_deg = args.angles.as_deref().map(parse_angles).transpose()?;
    let plot = args.plot.as_deref().map(plot_target).transpose()?;
    let opts = PhaseOptions { angles_deg, moments: args.moments };
    let report = phase_report(&scene, &opts).map_err(|e| {
        let flag = match &e {
            km::CoreError::Invalid { name, .. } if name == "angles_deg" => "--angles",
            _ => "--moments",
        };
        anyhow::Error::new(e).context(flag)
    })?;
    if let Some(out) = &args.out {
        crate::solve::write_json(out, &report.to_json(), std::slice::from_ref(&args.input.scene))?;
    }
    if let Some((dir, stem)) = plot {
        write_plot(&report, &dir, &stem)?;
    }
    match args.format {
        OutputFormat::Json => stdout::print_json(&report.to_json()),
        OutputFormat::Csv => stdout::print(&csv(&report)),
        OutputFormat::Table => stdout::print(&table(&report)),
    }
}

/// The angles of `--angles SPEC` (the syntax of `km bsdf`'s angle lists,
/// without `gauss:N`, whose nodes lie in one hemisphere).
fn parse_angles(spec: &str) -> Result<Vec<f64>> {
    if spec.trim().starts_with("gauss:") {
        bail!(
            "--angles {spec}: gauss:N gives angles in [0, 90) only; give a list or a range \
             START:STOP:STEP over [0, 180]"
        );
    }
    km::bsdf_file::parse_angles(spec).with_context(|| format!("--angles {spec}"))
}

/// The directory and stem of `--plot FILE.svg` (or `FILE.png`): both files
/// are drawn.
fn plot_target(path: &Path) -> Result<(PathBuf, String)> {
    let png = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("png"));
    let svg = if png { path.with_extension("svg") } else { path.to_path_buf() };
    crate::field::plot_target(&svg)
}

/// A channel's name in the table and chart: its label, with the wavelength.
fn channel_name(r: &PhaseReport, c: usize) -> String {
    match &r.wavelengths_nm {
        Some(w) if !r.labels[c].contains(&w[c].to_string()) => {
            format!("{} ({} nm)", r.labels[c], w[c])
        }
        _ => r.labels[c].clone(),
    }
}

fn table(r: &PhaseReport) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{NORMALISATION}");
    let _ = writeln!(
        s,
        "moments: chi_l = 2 pi integral p P_l dmu (DISORT's PMOM), chi_0 = 1, l = 0..{}{}",
        r.max_moment,
        r.default_streams.map_or(String::new(), |n| format!(
            " (2N, N = {n}: the default multi-flux streams, whose delta-M keeps chi_0..chi_{} \
             and truncates at chi_{})",
            r.max_moment - 1,
            r.max_moment
        ))
    );
    for (i, chans) in r.layers.iter().enumerate() {
        let _ = writeln!(s, "\nlayer {}", i + 1);
        let _ = writeln!(
            s,
            "  {:<16} {:<20} {:>10} {:>12} {:>12} {:>12} {:>10}",
            "channel", "kind", "g", "sigma_s", "sigma_a", "tau", "albedo"
        );
        for (c, ch) in chans.iter().enumerate() {
            let kind =
                if ch.scatters { ch.kind.to_string() } else { "none (no scattering)".into() };
            let _ = writeln!(
                s,
                "  {:<16} {:<20} {:>10.6} {:>12.6e} {:>12.6e} {:>12.6e} {:>10.6}",
                channel_name(r, c),
                kind,
                ch.g,
                ch.sigma_s,
                ch.sigma_a,
                ch.tau,
                ch.albedo
            );
        }
        particles_table(&mut s, r, chans);
        let live: Vec<usize> = (0..chans.len()).filter(|&c| chans[c].scatters).collect();
        if live.is_empty() {
            let _ = writeln!(s, "  the layer does not scatter: no phase function");
            continue;
        }
        let head: String = live.iter().map(|&c| format!(" {:>16}", r.labels[c])).collect();
        let _ = writeln!(s, "  p(theta), 1/sr\n  {:>10} {:>10}{head}", "theta_deg", "cos_theta");
        for (a, (t, mu)) in r.angles_deg.iter().zip(&r.cos_theta).enumerate() {
            let row: String = live.iter().map(|&c| format!(" {:>16.9e}", chans[c].p[a])).collect();
            let _ = writeln!(s, "  {t:>10.4} {mu:>10.6}{row}");
        }
        let _ = writeln!(s, "  moments chi_l\n  {:>10}{head}", "l");
        for l in 0..=r.max_moment {
            let row: String =
                live.iter().map(|&c| format!(" {:>16.9e}", chans[c].moments[l])).collect();
            let _ = writeln!(s, "  {l:>10}{row}");
        }
    }
    s
}

/// The Mie lines of a particle layer: per channel, each population and the mixture.
fn particles_table(s: &mut String, r: &PhaseReport, chans: &[ChannelPhase]) {
    if chans.iter().all(|c| c.particles.is_none()) {
        return;
    }
    let _ = writeln!(
        s,
        "  particles (Mie)\n  {:<16} {:<11} {:>10} {:>20} {:>12} {:>12} {:>12} {:>10}",
        "channel", "population", "x_eff", "m", "Q_ext", "Q_sca", "Q_abs", "g"
    );
    for (c, ch) in chans.iter().enumerate() {
        let Some(pp) = &ch.particles else { continue };
        for (k, p) in pp.populations.iter().enumerate() {
            let m = format!("{:.5}+{:.3e}i", p.m.re, p.m.im);
            let _ = writeln!(
                s,
                "  {:<16} {:<11} {:>10.4} {:>20} {:>12.6e} {:>12.6e} {:>12.6e} {:>10.6}",
                channel_name(r, c),
                k + 1,
                p.x_eff,
                m,
                p.q_ext,
                p.q_sca,
                p.q_abs,
                p.g
            );
        }
        let _ = writeln!(
            s,
            "  {:<16} {:<11} {:>10.4} {:>20} {:>12.6e} {:>12.6e} {:>12.6e} {:>10.6}",
            channel_name(r, c),
            "mixed",
            pp.x_eff,
            "",
            pp.q_ext,
            pp.q_sca,
            pp.q_abs,
            pp.g
        );
    }
}

/// One row per value: `layer,channel,quantity,key,value` (key: the angle in
/// degrees for `p`, `l` for `chi`, the population for particle values).
fn csv(r: &PhaseReport) -> String {
    let mut s = String::from("layer,channel,quantity,key,value\n");
    for (i, chans) in r.layers.iter().enumerate() {
        let layer = i + 1;
        for (c, ch) in chans.iter().enumerate() {
            let label = &r.labels[c];
            let mut row = |q: &str, key: &str, v: &str| {
                let _ = writeln!(s, "{layer},{label},{q},{key},{v}");
            };
            row("kind", "", ch.kind);
            row("scatters", "", if ch.scatters { "true" } else { "false" });
            for (q, v) in [
                ("sigma_a", ch.sigma_a),
                ("sigma_s", ch.sigma_s),
                ("thickness", ch.thickness),
                ("tau", ch.tau),
                ("albedo", ch.albedo),
                ("n", ch.n),
                ("g", ch.g),
            ] {
                row(q, "", &v.to_string());
            }
            if let Some(pp) = &ch.particles {
                for (k, p) in pp.populations.iter().enumerate() {
                    let key = (k + 1).to_string();
                    for (q, v) in [
                        ("x_eff", p.x_eff),
                        ("r_eff_um", p.r_eff_um),
                        ("m_re", p.m.re),
                        ("m_im", p.m.im),
                        ("q_ext", p.q_ext),
                        ("q_sca", p.q_sca),
                        ("q_abs", p.q_abs),
                        ("g_particles", p.g),
                    ] {
                        row(q, &key, &v.to_string());
                    }
                }
                for (q, v) in [
                    ("x_eff", pp.x_eff),
                    ("r_eff_um", pp.r_eff_um),
                    ("q_ext", pp.q_ext),
                    ("q_sca", pp.q_sca),
                    ("q_abs", pp.q_abs),
                    ("g_particles", pp.g),
                ] {
                    row(q, "mixed", &v.to_string());
                }
            }
            for (t, p) in r.angles_deg.iter().zip(&ch.p) {
                row("p", &t.to_string(), &p.to_string());
            }
            for (l, chi) in ch.moments.iter().enumerate() {
                row("chi", &l.to_string(), &chi.to_string());
            }
        }
    }
    s
}

/// `p(theta)` of every scattering layer and channel (the first
/// [`MAX_CURVES`]), on a log axis.
fn write_plot(r: &PhaseReport, dir: &Path, stem: &str) -> Result<()> {
    let mut series = Vec::new();
    let mut total = 0;
    for (i, chans) in r.layers.iter().enumerate() {
        for (c, ch) in chans.iter().enumerate().filter(|(_, ch)| ch.scatters) {
            total += 1;
            if series.len() == MAX_CURVES {
                continue;
            }
            let ch_name =
                if chans.len() > 1 { format!(", {}", channel_name(r, c)) } else { String::new() };
            let label = format!("layer {}{ch_name}: {}, g = {:.3}", i + 1, ch.kind, ch.g);
            let pts = r.angles_deg.iter().copied().zip(ch.p.iter().copied()).collect();
            series.push(Series::new(label, pts, Mark::Line, series.len()));
        }
    }
    if series.is_empty() {
        bail!("--plot: no layer of the scene scatters; there is no phase function to draw");
    }
    let shown = if total > series.len() {
        format!(" (the first {} of {total} curves)", series.len())
    } else {
        String::new()
    };
    let chart = LineChart {
        title: format!("km phase: p(theta), integral p dOmega = 1{shown}"),
        x_label: "scattering angle theta (degrees)".into(),
        y_label: "p (1/sr)".into(),
        y_log: true,
        x_range: Some((0.0, 180.0)),
        series,
        ..Default::default()
    };
    write_chart(dir, stem, &chart)
        .with_context(|| format!("drawing {}/{stem}.svg", dir.display()))?;
    Ok(())
}
