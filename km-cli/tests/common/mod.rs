//! The harness of the command's limit tests (limits.rs, hostile.rs): each
//! run of `km` is limited to 500 MB of address space (RLIMIT_AS, set in the
//! child before exec) and must end within 5 s.

#![allow(dead_code, clippy::unwrap_used)]

use std::io::Read;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// The memory limit of every run (500 MB).
pub const MEMORY: u64 = 500_000_000;
/// The time limit of every run (5 s).
pub const SECONDS: f64 = 5.0;

pub struct Run {
    pub status: ExitStatus,
    pub stdout: String,
    pub stderr: String,
    pub seconds: f64,
}

pub fn command(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_km"));
    c.args(args);
    // SAFETY: setrlimit is async-signal-safe and touches only the child.
    unsafe {
        c.pre_exec(|| {
            let lim = libc::rlimit { rlim_cur: MEMORY, rlim_max: MEMORY };
            if libc::setrlimit(libc::RLIMIT_AS, &lim) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    c
}

/// Wait for `child` at most `SECONDS` (then kill it and fail).
pub fn finish(mut child: Child, what: &str, t0: Instant) -> Run {
    let mut out = child.stdout.take();
    let mut err = child.stderr.take();
    // Drain the pipes in threads so a large output cannot block the child.
    let o = std::thread::spawn(move || {
        let mut s = Vec::new();
        if let Some(p) = out.as_mut() {
            let _ = p.read_to_end(&mut s);
        }
        s
    });
    let e = std::thread::spawn(move || {
        let mut s = Vec::new();
        if let Some(p) = err.as_mut() {
            let _ = p.read_to_end(&mut s);
        }
        s
    });
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait") {
            break s;
        }
        if t0.elapsed().as_secs_f64() > SECONDS {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{what}: still running after {SECONDS} s");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let seconds = t0.elapsed().as_secs_f64();
    Run {
        status,
        stdout: String::from_utf8_lossy(&o.join().unwrap()).into_owned(),
        stderr: String::from_utf8_lossy(&e.join().unwrap()).into_owned(),
        seconds,
    }
}

pub fn km(args: &[&str]) -> Run {
    let t0 = Instant::now();
    let child = command(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run km");
    finish(child, &args.join(" "), t0)
}

pub fn refused(r: &Run, names: &[&str]) {
    assert_eq!(r.status.code(), Some(2), "not refused: {} / {}", r.stderr, r.stdout);
    assert!(!r.stderr.contains("panicked"), "panic: {}", r.stderr);
    assert!(r.stdout.is_empty(), "stdout on a refusal: {}", r.stdout);
    for n in names {
        assert!(r.stderr.contains(n), "stderr does not say {n:?}: {}", r.stderr);
    }
}

pub fn ok(r: &Run) {
    assert!(r.status.success(), "failed: {}", r.stderr);
    assert!(r.seconds < SECONDS);
}

pub fn dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "km-{}-{tag}-{}",
        env!("CARGO_CRATE_NAME"),
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

pub fn example(name: &str) -> String {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..").join("examples").join(name);
    p.to_string_lossy().into_owned()
}

pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

pub fn json_number(text: &str, key: &str) -> f64 {
    let v: serde_json::Value = serde_json::from_str(text).expect("JSON on stdout");
    v["channels"][0][key].as_f64().or_else(|| v[key].as_f64()).expect(key)
}
