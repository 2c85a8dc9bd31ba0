//! `km mc FILE.mci`: the files it writes, and its refusals (a malformed
//! input names line and field; an output that is not ours, or the input,
//! or outside --out-dir, is never written).

use std::path::PathBuf;
use std::process::{Command, Output};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("km-mc-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn km(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().unwrap()
}

fn mci(out: &str) -> String {
    format!("1.0\n1\n{out} A\n2000\n0.02 0.02\n10 8 3\n1\n1.0\n1.37 1 50 0.9 0.2\n1.0\n")
}

#[test]
fn writes_mco_and_npz() {
    let d = dir("ok");
    let input = d.join("in.mci");
    std::fs::write(&input, mci("run.mco")).unwrap();
    let o =
        km(&["mc", input.to_str().unwrap(), "--out-dir", d.to_str().unwrap(), "--samples", "3000"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mco = std::fs::read_to_string(d.join("run.mco")).unwrap();
    assert!(
        mco.starts_with("A1")
            && mco.contains("\nA_rz\n")
            && mco.contains("3000 \t\t\t# No. of photons")
    );
    let npz = std::fs::read(d.join("run.npz")).unwrap();
    assert_eq!(&npz[..2], b"PK");
    // A second run replaces its own output.
    let o =
        km(&["mc", input.to_str().unwrap(), "--out-dir", d.to_str().unwrap(), "--samples", "100"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn refusals() {
    let d = dir("refuse");
    let input = d.join("in.mci");
    let run = |text: String| {
        std::fs::write(&input, text).unwrap();
        let o = km(&["mc", input.to_str().unwrap(), "--out-dir", d.to_str().unwrap()]);
        assert!(!o.status.success());
        String::from_utf8_lossy(&o.stderr).to_string()
    };
    // Not ours: an existing file that is not an .mco.
    std::fs::write(d.join("notes.mco"), "my notes").unwrap();
    let e = run(mci("notes.mco"));
    assert!(e.contains("not an MCML output"), "{e}");
    assert_eq!(std::fs::read_to_string(d.join("notes.mco")).unwrap(), "my notes");
    // The input itself, and paths outside --out-dir.
    let e = run(mci("in.mci"));
    assert!(e.contains("is the input file itself") || e.contains("not an MCML output"), "{e}");
    let e = run(mci("../x.mco"));
    assert!(e.contains("relative path below --out-dir"), "{e}");
    // A malformed input names line and field.
    let e = run("1.0\n1\nrun.mco A\n1000\n0.01 -1\n".into());
    assert!(e.contains("line 5") && e.contains("dr"), "{e}");
}
