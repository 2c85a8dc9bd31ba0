//! `km plan` refuses the scenes `km solve` refuses, with the same words and
//! exit code (the library side, every method on every example, is
//! km/tests/check.rs).

use std::process::Command;

fn km(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().unwrap()
}

#[test]
fn plan_and_solve_refuse_alike() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/");
    let paint = format!("{root}paint-over-primer.toml");
    let marble = format!("{root}marble-half-space.toml");
    // Refused by both: the dipole on a stack, direction-set with exit directions.
    for (scene, method) in [(&paint, "dipole"), (&paint, "direction-set")] {
        let plan = km(&["plan", scene, "--method", method]);
        let solve = km(&["solve", scene, "--method", method]);
        assert_eq!(plan.status.code(), solve.status.code(), "{method}");
        assert!(!plan.status.success(), "{method}: plan accepted a refused scene");
        assert_eq!(
            String::from_utf8_lossy(&plan.stderr),
            String::from_utf8_lossy(&solve.stderr),
            "{method}"
        );
        assert!(plan.stdout.is_empty());
    }
    // Accepted by both.
    let plan = km(&["plan", &marble, "--method", "dipole"]);
    assert!(plan.status.success(), "{}", String::from_utf8_lossy(&plan.stderr));
    assert!(km(&["solve", &marble, "--method", "dipole"]).status.success());
}
