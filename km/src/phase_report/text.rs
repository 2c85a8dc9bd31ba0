//! A phase report as text (`km phase`'s table and CSV).

use std::fmt::Write as _;

use super::{ChannelPhase, NORMALISATION, PhaseReport};

/// A channel's name in the table and chart: its label, with the wavelength.
pub fn channel_name(r: &PhaseReport, c: usize) -> String {
    match &r.wavelengths_nm {
        Some(w) if !r.labels[c].contains(&w[c].to_string()) => {
            format!("{} ({} nm)", r.labels[c], w[c])
        }
        _ => r.labels[c].clone(),
    }
}

/// The report as text for people: the normalisation, then per layer its
/// channels' coefficients, the particles' Mie values, `p(theta)` and the moments.
pub fn table(r: &PhaseReport) -> String {
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
pub fn csv(r: &PhaseReport) -> String {
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
