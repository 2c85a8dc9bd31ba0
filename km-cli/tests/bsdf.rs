//! `km bsdf` files read back by independent readers: numpy for the npz, and
//! a reader of the Fourier BSDF file written here in Python after pbrt-v3's
//! `FourierBSDFTable::Read`, `FourierBSDF::f` and `CatmullRomWeights`
//! (src/core/reflection.cpp, src/materials/fourier.cpp,
//! src/core/interpolation.cpp).

use std::path::{Path, PathBuf};
use std::process::Command;

/// A slab between air and glass: transmission with eta = 1.5 (the n^2
/// factors of the file), a peaked phase function (the correction).
const SCENE: &str = "
[[layer]]
tau = 1.0
albedo = 0.9
g = 0.5
n = 1.33
[substrate]
kind = \"transparent\"
n = 1.5
";

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("km-bsdf-test-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

fn km(args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().unwrap();
    assert!(out.status.success(), "km {args:?}: {}", String::from_utf8_lossy(&out.stderr));
}

/// Run a Python program; `None` (with the reason printed) when numpy cannot be imported.
fn python(code: &str, args: &[&Path]) -> Option<String> {
    let probe = Command::new("python3").args(["-c", "import numpy"]).output();
    if !probe.is_ok_and(|o| o.status.success()) {
        println!("SKIPPED: python3 with numpy is not available (pip install numpy)");
        return None;
    }
    let out = Command::new("python3").arg("-c").arg(code).args(args).output().unwrap();
    assert!(out.status.success(), "python: {}", String::from_utf8_lossy(&out.stderr));
    Some(String::from_utf8(out.stdout).unwrap())
}

#[test]
fn npz_loads_in_numpy_with_the_contract_names() {
    let scene = tmp("npz.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let npz = tmp("t.npz");
    let s = scene.to_str().unwrap();
    km(&[
        "bsdf",
        s,
        "--out",
        npz.to_str().unwrap(),
        "--theta-i",
        "0,30,60",
        "--theta-o",
        "0:90:10",
        "--phi",
        "0,90,180",
    ]);
    let code = r#"
import sys, json, numpy as np
d = np.load(sys.argv[1])
need = ['theta_i','theta_o','phi','brdf','btdf','reflectance','transmittance',
        'reflectance_specular','transmittance_direct','meta']
missing = [k for k in need if k not in d.files]
assert not missing, missing
assert d['brdf'].shape == (1, 3, 9, 3), d['brdf'].shape
assert d['btdf'].shape == (1, 3, 9, 3)
assert d['reflectance'].shape == (1, 3)
assert list(d['theta_i']) == [0.0, 30.0, 60.0]
assert list(d['phi']) == [0.0, 90.0, 180.0]
meta = json.loads(str(d['meta']))
assert meta['solver']['method'] == 'multiflux'
assert 'tau = 1.0' in meta['scene']
assert d['brdf'].dtype == np.float64
print(json.dumps({'brdf_0_0_0_0': float(d['brdf'][0,0,0,0]), 'R': d['reflectance'].tolist()}))
"#;
    let Some(out) = python(code, &[&npz]) else { return };
    // The same values from the library, independently of the file.
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    let sc = km_core::Scene::from_toml_str(SCENE).unwrap();
    let opts = km_multiflux::bsdf::BsdfOptions::default();
    let b = km_multiflux::bsdf::Bsdf::new(&sc, &[0.0, 30.0, 60.0], &[0.0], &opts).unwrap();
    assert_eq!(v["brdf_0_0_0_0"].as_f64().unwrap(), b.brdf(0, 0, 0, 0.0));
    assert_eq!(v["R"][0][2].as_f64().unwrap(), b.channels[0].reflectance[2]);
}

/// pbrt-v3's reader and evaluator, transcribed to Python: reads the file,
/// then for every row of the npz (direct evaluation by km) evaluates
/// `FourierBSDF::f` at the same geometry and prints the largest error
/// relative to the largest value.
const PBRT_READER: &str = r#"
import sys, struct, math, json
import numpy as np

def read(path):
    b = open(path, 'rb').read()
    assert b[:8] == b'SCATFUN\x01', 'header'
    flags, nMu, nCoeffs, mMax, nCh, nBases = struct.unpack_from('<6i', b, 8)
    eta, = struct.unpack_from('<f', b, 44)
    assert flags == 1 and nBases == 1 and nCh in (1, 3)
    off = 64
    mu = np.frombuffer(b, '<f4', nMu, off).astype(np.float64); off += 4 * nMu
    cdf = np.frombuffer(b, '<f4', nMu * nMu, off); off += 4 * nMu * nMu
    ol = np.frombuffer(b, '<i4', 2 * nMu * nMu, off); off += 8 * nMu * nMu
    a = np.frombuffer(b, '<f4', nCoeffs, off).astype(np.float64)
    return dict(mu=mu, nMu=nMu, mMax=mMax, nCh=nCh, eta=eta,
                offset=ol[0::2], m=ol[1::2], a=a, cdf=cdf)

def find_interval(size, pred):
    first, length = 0, size
    while length > 0:
        half = length >> 1
        middle = first + half
        if pred(middle):
            first = middle + 1
            length -= half + 1
        else:
            length = half
    return min(max(first - 1, 0), size - 2)

def catmull_rom_weights(nodes, x):
    size = len(nodes)
    if not (x >= nodes[0] and x <= nodes[size - 1]):
        return None
    idx = find_interval(size, lambda i: nodes[i] <= x)
    offset = idx - 1
    x0, x1 = nodes[idx], nodes[idx + 1]
    t = (x - x0) / (x1 - x0); t2 = t * t; t3 = t2 * t
    w = [0.0] * 4
    w[1] = 2 * t3 - 3 * t2 + 1
    w[2] = -2 * t3 + 3 * t2
    if idx > 0:
        w0 = (t3 - 2 * t2 + t) * (x1 - x0) / (x1 - nodes[idx - 1])
        w[0] = -w0; w[2] += w0
    else:
        w0 = t3 - 2 * t2 + t
        w[0] = 0; w[1] -= w0; w[2] += w0
    if idx + 2 < size:
        w3 = (t3 - t2) * (x1 - x0) / (nodes[idx + 2] - x0)
        w[1] -= w3; w[3] = w3
    else:
        w3 = t3 - t2
        w[1] -= w3; w[2] += w3; w[3] = 0
    return offset, w

def fourier(a, m, cos_phi):
    value = 0.0
    c_prev, c_cur = cos_phi, 1.0
    for k in range(m):
        value += a[k] * c_cur
        c_next = 2 * cos_phi * c_cur - c_prev
        c_prev, c_cur = c_cur, c_next
    return value

def f(t, muI, muO, cos_phi):
    wi = catmull_rom_weights(t['mu'], muI)
    wo = catmull_rom_weights(t['mu'], muO)
    if wi is None or wo is None:
        return 0.0
    (oi, wI), (oo, wO) = wi, wo
    nMu, mMax, nCh = t['nMu'], t['mMax'], t['nCh']
    ak = np.zeros(mMax * nCh)
    mmax = 0
    for b in range(4):
        for a_ in range(4):
            weight = wI[a_] * wO[b]
            if weight != 0:
                pair = (oo + b) * nMu + (oi + a_)
                m = int(t['m'][pair]); off = int(t['offset'][pair])
                mmax = max(mmax, m)
                for c in range(nCh):
                    ak[c * mMax:c * mMax + m] += weight * t['a'][off + c * m: off + c * m + m]
    Y = max(0.0, fourier(ak, mmax, cos_phi))
    scale = 1.0 / abs(muI) if muI != 0 else 0.0
    if muI * muO > 0:
        eta = 1.0 / t['eta'] if muI > 0 else t['eta']
        scale *= eta * eta
    return Y * scale

t = read(sys.argv[1])
d = np.load(sys.argv[2])
worst, top = 0.0, 0.0
for i, ti in enumerate(d['theta_i']):
    for o, to in enumerate(d['theta_o']):
        for p, ph in enumerate(d['phi']):
            cphi = math.cos(math.radians(ph - 180.0))
            muI = -math.cos(math.radians(ti))
            r = f(t, muI, math.cos(math.radians(to)), cphi)
            tr = f(t, muI, -math.cos(math.radians(to)), cphi)
            kr, kt = d['brdf'][0, i, o, p], d['btdf'][0, i, o, p]
            worst = max(worst, abs(r - kr), abs(tr - kt))
            top = max(top, abs(kr), abs(kt))
print(json.dumps({'max_abs': worst, 'max_value': top, 'eta': float(t['eta'])}))
"#;

/// Fourier file with `n` polar nodes (0 to 90 degrees, uniform in theta),
/// read back by the pbrt-v3 reader at the angles `theta` (degrees):
/// returns (largest error, largest value, eta).
fn fourier_error(n: usize, theta: &str, theta_o: &str) -> Option<(f64, f64, f64)> {
    let scene = tmp(&format!("f{n}.toml"));
    std::fs::write(&scene, SCENE).unwrap();
    let file = tmp(&format!("f{n}-{}.bsdf", theta.len()));
    let npz = tmp(&format!("f{n}-{}.npz", theta.len()));
    let step = format!("0:90:{}", 90.0 / n as f64);
    let s = scene.to_str().unwrap();
    km(&["bsdf", s, "--out", file.to_str().unwrap(), "--format", "fourier", "--theta-i", &step]);
    km(&[
        "bsdf",
        s,
        "--out",
        npz.to_str().unwrap(),
        "--theta-i",
        theta,
        "--theta-o",
        theta_o,
        "--phi",
        "0,40,90,150,180,250",
    ]);
    let out = python(PBRT_READER, &[&file, &npz])?;
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    Some((
        v["max_abs"].as_f64().unwrap(),
        v["max_value"].as_f64().unwrap(),
        v["eta"].as_f64().unwrap(),
    ))
}

#[test]
fn fourier_file_at_the_nodes_equals_the_table() {
    // At node angles the Catmull-Rom weights are (0, 1, 0, 0): the reader
    // returns the stored series, so only float32 storage (6e-8 relative) and
    // the series' tail rule (1e-5 of a_0 per pair) separate it from km.
    let Some((err, top, eta)) = fourier_error(24, "0,15,48.75,71.25", "3.75,30,63.75,86.25") else {
        return;
    };
    println!("nodes: max |pbrt - km| = {err:.2e} of max {top:.3}, eta {eta}");
    assert!((eta - 1.5).abs() < 1e-6, "eta {eta}");
    assert!(err < 2e-5 * top, "{err} vs {top}");
}

#[test]
fn fourier_file_interpolation_error_falls_with_the_node_count() {
    // Off the nodes: the Catmull-Rom spline in mu_i and mu_o. Measured on
    // this slab (max error / max value): 12 nodes 3.1e-3, 24 nodes 3.6e-4,
    // 48 nodes 8.1e-5, 96 nodes 5.9e-6. Bounds: 2x the measured values, and
    // the error must fall by at least 3x per doubling.
    let theta = "7,22,41,58,77";
    let theta_o = "11,33,52,68,83";
    let mut prev: Option<f64> = None;
    for (n, bound) in [(12, 6e-3), (24, 7.2e-4), (48, 1.6e-4)] {
        let Some((err, top, _)) = fourier_error(n, theta, theta_o) else { return };
        let rel = err / top;
        println!("{n} nodes: interpolation error {rel:.2e} of the largest value");
        assert!(rel < bound, "{n} nodes: {rel}");
        if let Some(p) = prev {
            assert!(rel < p / 3.0, "{n} nodes: {rel} vs {p}");
        }
        prev = Some(rel);
    }
}

#[test]
fn bad_bsdf_requests_are_refused() {
    let scene = tmp("bad.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let s = scene.to_str().unwrap();
    let fails = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().unwrap();
        assert!(!out.status.success(), "{args:?} should fail");
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    let out = tmp("x.npz");
    let o = out.to_str().unwrap();
    assert!(fails(&["bsdf", s, "--out", o, "--theta-i", "95"]).contains("theta_i"));
    assert!(fails(&["bsdf", s, "--out", o, "--phi", "a,b"]).contains("phi"));
    assert!(fails(&["bsdf", s, "--out", o, "--theta-o", "0:90:0"]).contains("STEP"));
    assert!(fails(&["bsdf", s]).contains("--out"));
    // Never over a directory.
    let dir = tmp("adir");
    std::fs::create_dir_all(&dir).unwrap();
    assert!(fails(&["bsdf", s, "--out", dir.to_str().unwrap()]).contains("not a regular file"));
    // Four channels cannot go into a Fourier file.
    let four = tmp("four.toml");
    std::fs::write(&four, "[[layer]]\ntau = [1.0, 1.0, 1.0, 1.0]\nalbedo = 0.5\n").unwrap();
    let f = tmp("four.bsdf");
    assert!(
        fails(&["bsdf", four.to_str().unwrap(), "--out", f.to_str().unwrap()])
            .contains("1 or 3 channels")
    );
    assert!(!f.exists());
}
