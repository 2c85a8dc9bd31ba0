//! Progress on stderr (docs/cli.md, km-cli/src/progress.rs): drawn for a
//! solve expected to last more than 2 s when stderr is a terminal (here a
//! pseudo-terminal), never with `--quiet`, never when stderr is a pipe.

use std::io::Read;
use std::os::fd::{FromRawFd, OwnedFd};
use std::process::{Command, Stdio};

/// A layer of g = 0.99 lit at 80 degrees with the BRDF at four directions;
/// at 80 streams its work estimate (about 1.1e9 units of eq. W1) makes the
/// expected time above 2 s.
const PEAKED: &str = "[light]\nkind = \"collimated\"\ntheta_deg = 80.0\n\n\
    [[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.99\nn = 1.33\n\n\
    [substrate]\nkind = \"transparent\"\nn = 1.5\n\n\
    [output]\ndirections_deg = [[0.0, 0.0], [30.0, 180.0], [60.0, 180.0], [80.0, 180.0]]\n";

fn scene() -> String {
    let dir = std::env::temp_dir().join(format!("km-progress-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("peaked.toml");
    std::fs::write(&p, PEAKED).unwrap();
    p.to_string_lossy().into_owned()
}

/// Run `km ARGS` with stderr on a fresh pseudo-terminal; what it wrote there.
fn on_terminal(args: &[&str]) -> String {
    let (mut master, mut slave) = (0, 0);
    // SAFETY: openpty writes two file descriptors into the given integers;
    // the null pointers ask for no name, no termios and no window size.
    let rc = unsafe {
        libc::openpty(
            &mut master,
            &mut slave,
            std::ptr::null_mut(),
            std::ptr::null(),
            std::ptr::null(),
        )
    };
    assert_eq!(rc, 0, "openpty failed");
    // SAFETY: both descriptors were just opened by openpty and are owned here.
    let (master, slave) = unsafe { (OwnedFd::from_raw_fd(master), OwnedFd::from_raw_fd(slave)) };
    let mut child = Command::new(env!("CARGO_BIN_EXE_km"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::from(slave))
        .spawn()
        .unwrap();
    // The parent's copy of the slave went with the Command; reading the
    // master ends (EIO) once the child has closed its stderr.
    let mut reader = std::fs::File::from(master);
    let mut text = Vec::new();
    let mut buf = [0u8; 4096];
    while let Ok(k) = reader.read(&mut buf) {
        if k == 0 {
            break;
        }
        text.extend_from_slice(&buf[..k]);
    }
    assert!(child.wait().unwrap().success());
    String::from_utf8_lossy(&text).into_owned()
}

#[test]
fn a_long_multiflux_solve_shows_a_bar_on_a_terminal_and_not_with_quiet() {
    let p = scene();
    let args = ["solve", &p, "--streams", "80"];
    let shown = on_terminal(&args);
    assert!(shown.contains("multiflux") && shown.contains("expected"), "{shown:?}");
    let quiet = on_terminal(&[&args[..], &["--quiet"]].concat());
    assert!(quiet.is_empty(), "--quiet wrote {quiet:?}");
}

#[test]
fn nothing_is_drawn_when_stderr_is_not_a_terminal() {
    let p = scene();
    let out = Command::new(env!("CARGO_BIN_EXE_km"))
        .args(["solve", &p, "--streams", "80"])
        .output()
        .unwrap();
    assert!(out.status.success());
    assert!(out.stderr.is_empty(), "{:?}", String::from_utf8_lossy(&out.stderr));
    assert!(!out.stdout.is_empty());
}

/// Photons of the seed scene that one thread traces in about `seconds` on
/// this machine, from a timed pilot run (the solver's own `seconds`).
fn photons_for(seed: &str, seconds: f64) -> u64 {
    let pilot = 200_000u64;
    let out = Command::new(env!("CARGO_BIN_EXE_km"))
        .args(["solve", seed, "-m", "mc", "--threads", "1", "--json"])
        .args(["--samples", &pilot.to_string()])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let took = v["seconds"].as_f64().expect("`seconds` in the JSON");
    assert!(took > 0.0, "pilot took {took} s");
    ((pilot as f64 * seconds / took) as u64).clamp(1_000, 400_000_000)
}

#[test]
fn a_long_monte_carlo_run_counts_photons_on_a_terminal() {
    // The bar is drawn once the run has lasted 0.5 s and is projected past
    // SHOW_ABOVE_S = 2 s. The photon count is sized from a pilot run to take
    // about 5 s here, so that neither a fast nor a loaded machine decides the
    // outcome (a fixed count of 4e6 took 2 to 4 s on one machine and under
    // 2 s on another).
    let seed = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/seed-three-layers.toml");
    let n = photons_for(seed, 5.0).to_string();
    let shown = on_terminal(&["solve", seed, "-m", "mc", "--samples", &n, "--threads", "1"]);
    assert!(shown.contains("photons"), "{n} photons: {shown:?}");
}

#[test]
fn a_short_monte_carlo_run_draws_nothing_on_a_terminal() {
    // The other side of the same rule: a run of about 0.1 s never shows a bar.
    let seed = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/seed-three-layers.toml");
    let n = photons_for(seed, 0.1).to_string();
    let shown = on_terminal(&["solve", seed, "-m", "mc", "--samples", &n, "--threads", "1"]);
    assert!(shown.is_empty(), "{n} photons: {shown:?}");
}
