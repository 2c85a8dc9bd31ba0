//! `km bsdf` files people can use: the CSV's totals file, normal incidence
//! in the default grid, plots named by channel, and a spectral scene's
//! Fourier file as luminance and RGB of its spectrum.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("km-bsdf-files-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn km(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().expect("run km")
}

fn ok(args: &[&str]) -> String {
    let out = km(args);
    assert!(out.status.success(), "km {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

const SLAB: &str = "[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.5\nn = 1.33\n\
                    [substrate]\nkind = \"transparent\"\nn = 1.5\n";

#[test]
fn csv_has_a_totals_file_with_the_delta_parts() {
    let d = dir("totals");
    let scene = d.join("slab.toml");
    std::fs::write(&scene, SLAB).unwrap();
    let out = d.join("slab.csv");
    let err = ok(&["bsdf", s(&scene), "--out", s(&out), "--theta-i", "0,30", "--phi", "0,180"]);
    let totals = d.join("slab.totals.csv");
    assert!(err.contains("slab.totals.csv"), "{err}");
    let text = std::fs::read_to_string(&totals).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "channel,theta_i_deg,reflectance,reflectance_specular,transmittance,transmittance_direct"
    );
    // The library's totals for the same grid, to the bit.
    let sc = km_core::Scene::from_toml_str(SLAB).unwrap();
    let b = km_multiflux::bsdf::Bsdf::new(&sc, &[0.0, 30.0], &[0.0, 30.0], &Default::default())
        .unwrap();
    let c = &b.channels[0];
    let rows: Vec<Vec<f64>> =
        lines.map(|l| l.split(',').skip(1).map(|x| x.parse().unwrap()).collect()).collect();
    assert_eq!(rows.len(), 2, "{text}");
    for (i, row) in rows.iter().enumerate() {
        let want = [
            [0.0, 30.0][i],
            c.reflectance[i],
            c.reflectance_specular[i],
            c.transmittance[i],
            c.transmittance_direct[i],
        ];
        assert_eq!(row[..], want[..], "row {i}");
        assert!(row[2] > 0.0 && row[4] > 0.0, "a slab in air has both delta parts: {row:?}");
    }
}

#[test]
fn the_default_grid_has_normal_incidence() {
    let d = dir("default");
    let scene = d.join("slab.toml");
    std::fs::write(&scene, SLAB).unwrap();
    let out = d.join("d.csv");
    ok(&["bsdf", s(&scene), "--out", s(&out), "--phi", "0"]);
    let totals = std::fs::read_to_string(d.join("d.totals.csv")).unwrap();
    let theta_i: Vec<f64> =
        totals.lines().skip(1).map(|l| l.split(',').nth(1).unwrap().parse().unwrap()).collect();
    assert_eq!(theta_i.len(), 33, "0 and the 32 Gauss angles");
    assert_eq!(theta_i[0], 0.0);
    // The exit grid stays the 32 Gauss angles (the energy check's rule):
    // the table's rows are 33 x 32 x 1 azimuth.
    let table = std::fs::read_to_string(&out).unwrap();
    let rows = table.lines().filter(|l| !l.starts_with('#')).count() - 1;
    assert_eq!(rows, 33 * 32);
}

#[test]
fn plots_are_named_by_channel() {
    let d = dir("plots");
    let rgb = d.join("rgb.toml");
    std::fs::write(
        &rgb,
        "[[layer]]\ntau = 1\nalbedo = [0.9, 0.5, 0.2]\n[substrate]\nkind = \"black\"\n",
    )
    .unwrap();
    let spectral = d.join("spectral.toml");
    std::fs::write(
        &spectral,
        "[spectrum]\nwavelengths_nm = [450, 650]\n[[layer]]\ntau = 1\nalbedo = [0.9, 0.5]\n\
         [substrate]\nkind = \"black\"\n",
    )
    .unwrap();
    let grid = ["--theta-i", "0,30", "--theta-o", "0:90:30"];
    let (pr, ps) = (d.join("rgb"), d.join("spectral"));
    ok(&[&["bsdf", s(&rgb), "--plot", s(&pr)][..], &grid[..]].concat());
    ok(&[&["bsdf", s(&spectral), "--plot", s(&ps)][..], &grid[..]].concat());
    for name in ["bsdf-polar-R.svg", "bsdf-polar-G.svg", "bsdf-polar-B.svg", "bsdf-brdf-B-i0.svg"] {
        assert!(pr.join(name).is_file(), "{name}");
    }
    assert!(!pr.join("bsdf-polar-0.svg").exists(), "named by index");
    for name in ["bsdf-polar-450nm.svg", "bsdf-polar-650nm.png", "bsdf-brdf-650nm-i30.svg"] {
        assert!(ps.join(name).is_file(), "{name}");
    }
    // The pictures say which channel they show.
    let svg = std::fs::read_to_string(ps.join("bsdf-polar-450nm.svg")).unwrap();
    assert!(svg.contains("450 nm"), "the channel in the title");
}

/// The coefficient blocks of a Fourier BSDF file: per pair (`o * nMu + i`),
/// per channel, the stored series.
fn fourier_blocks(path: &Path) -> (usize, Vec<Vec<Vec<f32>>>) {
    let b = std::fs::read(path).unwrap();
    let int = |at: usize| i32::from_le_bytes(b[at..at + 4].try_into().unwrap()) as usize;
    assert_eq!(&b[..8], b"SCATFUN\x01");
    let (n_mu, n_coeffs, n_ch) = (int(12), int(16), int(24));
    let mut off = 64 + 4 * n_mu + 4 * n_mu * n_mu;
    let ol: Vec<(usize, usize)> =
        (0..n_mu * n_mu).map(|k| (int(off + 8 * k), int(off + 8 * k + 4))).collect();
    off += 8 * n_mu * n_mu;
    let a: Vec<f32> = (0..n_coeffs)
        .map(|k| f32::from_le_bytes(b[off + 4 * k..off + 4 * k + 4].try_into().unwrap()))
        .collect();
    let blocks = ol
        .iter()
        .map(|&(o, m)| (0..n_ch).map(|c| a[o + c * m..o + (c + 1) * m].to_vec()).collect())
        .collect();
    (n_ch, blocks)
}

#[test]
fn a_spectral_fourier_file_holds_the_luminance_and_rgb_of_the_spectrum() {
    let d = dir("fourier");
    let mono = d.join("mono.toml");
    std::fs::write(&mono, SLAB).unwrap();
    // The same slab at four wavelengths: a flat spectrum, whose colour under
    // D65 is the illuminant's white: Y = 1 (CIE 015 eq. 7.1-7.4, k = 100 /
    // sum S ybar) and linear sRGB (1, 1, 1) to the 1e-3 by which the D65
    // table's white (95.047, 100, 108.883) differs from sRGB's (95.05, 100, 108.90).
    let flat = d.join("flat.toml");
    std::fs::write(&flat, format!("[spectrum]\nwavelengths_nm = [450, 550, 650, 750]\n{SLAB}"))
        .unwrap();
    let grid = ["--format", "fourier", "--theta-i", "0:90:15"];
    let (fm, ff) = (d.join("mono.bsdf"), d.join("flat.bsdf"));
    ok(&[&["bsdf", s(&mono), "--out", s(&fm)][..], &grid[..]].concat());
    let err = ok(&[&["bsdf", s(&flat), "--out", s(&ff)][..], &grid[..]].concat());
    assert!(err.contains("luminance Y and linear sRGB"), "{err}");
    let (nm, m) = fourier_blocks(&fm);
    let (nf, f) = fourier_blocks(&ff);
    assert_eq!((nm, nf), (1, 3));
    let top = m.iter().flatten().flatten().fold(0f32, |t, x| t.max(x.abs()));
    let mut compared = 0;
    for (pm, pf) in m.iter().zip(&f) {
        let n = pm[0].len().min(pf[0].len());
        for k in 0..n {
            let a = pm[0][k];
            // Y: float32 storage (6e-8) and the Rec. 709 weights' last digits.
            assert!((pf[0][k] - a).abs() <= 1e-5 * top, "Y {} vs {a}", pf[0][k]);
            for c in [1, 2] {
                assert!((pf[c][k] - a).abs() <= 2e-3 * top, "channel {c}: {} vs {a}", pf[c][k]);
            }
            compared += 1;
        }
    }
    assert!(compared > 100, "{compared} coefficients compared");
    // A scene of four labelled channels (not a spectrum) is still refused.
    let four = d.join("four.toml");
    std::fs::write(&four, "[[layer]]\ntau = 1\nalbedo = [0.9, 0.8, 0.7, 0.6]\n").unwrap();
    let out = km(&[&["bsdf", s(&four), "--out", s(&d.join("four.bsdf"))][..], &grid[..]].concat());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("needs 1 or 3 channels"), "{err}");
}
