//! Text for people: a solution as a table, a scene and a plan in words (what
//! the `km` command prints without `--json`).

use std::fmt::Write;

use crate::{ChannelResult, Light, Method, Plan, Scene, Solution, Substrate};

/// Reads one number of a channel's result.
type Getter = fn(&ChannelResult) -> f64;

/// A table of the solution, one column per channel, then the accuracy
/// target met and every note. `scene` supplies the output directions when
/// the solution does not carry them.
pub fn table(sol: &Solution, scene: Option<&Scene>) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "method: {}   solver time: {}", sol.method, seconds(sol.seconds));
    let _ = write!(s, "{:<24}", "");
    for l in &sol.labels {
        let _ = write!(s, "{l:>14}");
    }
    let _ = writeln!(s);
    let rows: [(&str, Getter); 5] = [
        ("reflectance", |c| c.reflectance),
        ("  specular part", |c| c.reflectance_specular),
        ("transmittance", |c| c.transmittance),
        ("  direct part", |c| c.transmittance_direct),
        ("absorptance", |c| c.absorptance),
    ];
    for (name, get) in rows {
        let _ = write!(s, "{name:<24}");
        for c in &sol.channels {
            let _ = write!(s, "{:>14.6}", get(c));
        }
        let _ = writeln!(s);
    }
    let scene_dirs = scene.map(|s| &s.channels[0].directions_deg);
    let dirs = if sol.directions.is_empty() {
        scene_dirs.unwrap_or(&sol.directions)
    } else {
        &sol.directions
    };
    for (what, pick) in [("BRDF", 0usize), ("BTDF", 1usize)] {
        if sol
            .channels
            .iter()
            .all(|c| if pick == 0 { c.brdf.is_empty() } else { c.btdf.is_empty() })
        {
            continue;
        }
        for (i, d) in dirs.iter().enumerate() {
            let _ = write!(s, "{:<24}", format!("{what} ({:.1}, {:.1})", d[0], d[1]));
            for c in &sol.channels {
                let v = if pick == 0 { &c.brdf } else { &c.btdf };
                let _ = write!(s, "{:>14.6}", v.get(i).copied().unwrap_or(f64::NAN));
            }
            let _ = writeln!(s);
        }
    }
    if let Some(a) = &sol.accuracy {
        let _ = writeln!(
            s,
            "accuracy target {:e} met; limited by {} (estimate {:.2e})",
            a.target, a.limited_by, a.estimate
        );
    }
    for note in &sol.notes {
        let _ = writeln!(s, "note: {note}");
    }
    s
}

fn seconds(t: f64) -> String {
    if t < 1e-3 {
        format!("{:.2} us", t * 1e6)
    } else if t < 1.0 {
        format!("{:.3} ms", t * 1e3)
    } else {
        format!("{t:.3} s")
    }
}

/// What a scene describes, in words (`km check`).
pub fn describe(scene: &Scene) -> String {
    let mut s = String::new();
    let c0 = &scene.channels[0];
    let _ = writeln!(s, "channels: {} ({})", scene.channels.len(), scene.labels.join(", "));
    match c0.light {
        Light::Collimated { theta_deg } => {
            let _ = writeln!(s, "light: collimated at {theta_deg} degrees");
        }
        Light::Diffuse => {
            let _ = writeln!(s, "light: diffuse");
        }
    }
    let _ = writeln!(s, "ambient index: {}", c0.ambient_n);
    for (ch, c) in scene.channels.iter().enumerate() {
        let _ = writeln!(s, "channel {}:", scene.labels[ch]);
        for (i, l) in c.layers.iter().enumerate() {
            let _ = writeln!(
                s,
                "  layer {}: sigma_a = {}, sigma_s = {}, thickness = {}, tau = {}, albedo = {:.6}, g = {}, n = {}",
                i + 1,
                l.sigma_a,
                l.sigma_s,
                l.thickness,
                l.tau(),
                l.albedo(),
                l.g(),
                l.n
            );
        }
        let sub = match c.substrate {
            Substrate::Transparent { n } => format!("transparent, n = {n}"),
            Substrate::Lambertian { albedo } => format!("lambertian, albedo = {albedo}"),
            Substrate::Black => "black".into(),
        };
        let _ = writeln!(s, "  substrate: {sub}");
    }
    if !c0.directions_deg.is_empty() {
        let _ = writeln!(s, "output directions (theta, phi): {:?}", c0.directions_deg);
    }
    s
}

/// A plan in plain words (`km plan`).
pub fn plan_words(plan: &Plan, method: Method) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "plan for method {}", method.name());
    if plan.all_effects {
        let _ = writeln!(s, "planner off (--all-effects): every effect is computed");
    }
    let effects =
        if plan.effects.is_empty() { "none".to_string() } else { plan.effects.join(", ") };
    let _ = writeln!(s, "effects present: {effects}");
    let _ = writeln!(s, "layers taking part: {}", plan.active_layers);
    for (i, l) in plan.layers.iter().enumerate() {
        let mut what = Vec::new();
        what.push(if l.interface_above { "Fresnel interface above" } else { "no interface above" });
        what.push(if l.scatters { "scatters" } else { "absorbs only: closed-form attenuation" });
        if l.half_space {
            what.push("half-space");
        }
        let _ = writeln!(s, "  layer {}: {}", i + 1, what.join(", "));
    }
    if plan.skipped.is_empty() {
        let _ = writeln!(s, "skipped: nothing");
    }
    for name in &plan.skipped {
        let why = plan.reasons.get(name).map(String::as_str).unwrap_or("");
        let name = name.name();
        let _ = writeln!(s, "skipped {name}: {why}");
    }
    let per_method = match method {
        Method::Km => "two-flux closed form per layer, adding for the stack",
        Method::Multiflux if plan.azimuth_independent => {
            "Fourier order m = 0 only; eigen-solve only for scattering layers"
        }
        Method::Multiflux => "Fourier orders m = 0..M for the requested directions",
        Method::Mc if plan.angular_tallies => "photon tracing with totals and angular bins",
        Method::Mc => "photon tracing with totals only",
        Method::Dipole => "closed form for a semi-infinite layer",
    };
    let _ = writeln!(s, "{}: {per_method}", method.name());
    s
}
