//! MCML's files: the `.mci` reader's refusals (line and field), the `.mco`
//! text (sections, counts, C number formats) and its sums against the
//! run's totals (identities photon by photon, so to rounding).

use km_montecarlo::McOptions;
use km_montecarlo::mcml::{c_e, c_g, parse_mci, run_mci};

const ONE: &str = "1.0 # version\n1\n\nout.mco A\n4000\n0.02 0.02\n10 8 3\n2\n1.0\n\
                   1.37 1 50 0.9 0.1\n1.37 2 20 0.5 0.1\n1.0\n";

#[test]
fn refusals_name_line_and_field() {
    let cases = [
        ("1.0\n1\nout.mco A\n1000\n", "line 5: dz, dr"),
        ("1.0\n1\nout.mco A\nmany\n", "line 4: number of photons"),
        ("1.0\n1\nout.mco A\n1000\n0.01 0\n", "line 5: dr"),
        ("1.0\n1\nout.mco A\n1000\n0.01 0.01\n0 5 1\n", "line 6: nz"),
        ("1.0\n1\nout.mco A\n1000\n0.01 0.01\n5 5 40000\n", "line 6: na"),
        (
            "1.0\n1\nout.mco A\n1000\n0.01 0.01\n5 5 1\n1\n1\n1.4 1 10 1.0 0.1\n1\n",
            "line 9: layer g",
        ),
        ("1.0\n1\nout.mco A\n1000\n0.01 0.01\n5 5 1\n1\n1\n1.4 1 10 0.5\n1\n", "layer d"),
        ("1.0\n1\nout.mco A\n1000\n0.01 0.01\n5 5 1\n1\n0.5\n", "line 8: n for medium above"),
    ];
    for (text, want) in cases {
        let e = parse_mci(text).unwrap_err().to_string();
        assert!(e.contains(want), "{text:?}: {e}");
    }
    let twice = format!("1.0\n2\n{}{}", &ONE[17..], &ONE[17..]);
    let e = parse_mci(&twice).unwrap_err().to_string();
    assert!(e.contains("also the output of the run on line"), "{e}");
}

#[test]
fn c_number_formats() {
    // The outputs of C's printf for these values.
    assert_eq!(c_e(2.799, 4, 12), "  2.7990E+00");
    assert_eq!(c_e(-1.5e-7, 4, 12), " -1.5000E-07");
    assert_eq!(c_e(0.0, 4, 12), "  0.0000E+00");
    assert_eq!(c_g(0.0243729), "0.0243729");
    assert_eq!(c_g(1e-5), "1E-05");
    assert_eq!(c_g(100000.0), "100000");
    assert_eq!(c_g(1234567.0), "1.23457E+06");
    assert_eq!(c_g(0.1), "0.1");
    assert_eq!(c_g(1.37), "1.37");
}

#[test]
fn mco_sections_and_sums() {
    let file = parse_mci(ONE).unwrap();
    let run = &file.runs[0];
    let (m, sol, _) = run_mci(run, None, &McOptions { seed: 3, ..Default::default() }).unwrap();
    let c = &sol.channels[0];
    // Rsp + Rd + A + Tt = 1 (no photon lost here), to rounding.
    assert!((c.absorptance + c.reflectance + c.transmittance - 1.0).abs() < 1e-12);
    assert!((m.rsp + m.rd[0] + m.a[0] + m.tt[0] - 1.0).abs() < 1e-12);
    // A_z (overflow folded into the last bin) integrates to A, the layers'.
    let a_z: f64 = m.a_z[0].iter().map(|a| a * run.dz).sum();
    assert!((a_z - m.a[0]).abs() < 1e-12, "{a_z} {}", m.a[0]);
    let a_l: f64 = m.a_l[0].iter().sum();
    assert!((a_l - m.a[0]).abs() < 1e-12);
    // Rd(r) integrates to Rd over the annuli.
    let area = |i: usize| 2.0 * std::f64::consts::PI * (i as f64 + 0.5) * run.dr * run.dr;
    let rd: f64 = m.rd_r[0].iter().enumerate().map(|(i, x)| x * area(i)).sum();
    assert!((rd - m.rd[0]).abs() < 1e-12);
    // The text: MCML's sections in order, each with its count of numbers.
    let text = m.text(run, run.photons, 1.0);
    assert!(text.starts_with("A1 \t# Version number of the file format."));
    let names =
        ["InParm", "RAT", "A_l", "A_z", "Rd_r", "Rd_a", "Tt_r", "Tt_a", "A_rz", "Rd_ra", "Tt_ra"];
    let mut seen: Vec<(&str, usize)> = Vec::new();
    for line in text.lines() {
        let data = line.split('#').next().unwrap_or("");
        let mut tokens = data.split_whitespace().peekable();
        let section = tokens.peek().and_then(|&first| names.iter().find(|n| **n == first));
        if let Some(name) = section {
            seen.push((name, 0));
            continue;
        }
        if let Some(last) = seen.last_mut() {
            last.1 += tokens.filter(|t| t.parse::<f64>().is_ok()).count();
        }
    }
    let want = [
        ("InParm", 0),
        ("RAT", 4),
        ("A_l", 2),
        ("A_z", 10),
        ("Rd_r", 8),
        ("Rd_a", 3),
        ("Tt_r", 8),
        ("Tt_a", 3),
        ("A_rz", 80),
        ("Rd_ra", 24),
        ("Tt_ra", 24),
    ];
    let got: Vec<(&str, usize)> = seen.iter().map(|(n, c)| (*n, *c)).collect();
    // InParm's own numbers (photons, grid, layers) are not counted here.
    assert_eq!(got[1..], want[1..]);
    assert_eq!(got[0].0, "InParm");
}
