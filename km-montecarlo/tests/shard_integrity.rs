//! Corrupted, forged and oversized shards are refused by the merge, naming
//! the part; nothing is allocated from a count before it is checked.

use km_core::Scene;
use km_montecarlo::{McError, McOptions, Partial, merge, run_shard};

const SCENE: &str = "[[layer]]\ntau = 1.0\nalbedo = 0.9\nn = 1.4\n";

fn parts() -> (Vec<Partial>, McOptions) {
    let s = Scene::from_toml_str(SCENE).unwrap();
    let o = McOptions { samples: 4_000, seed: 3, ..Default::default() };
    ((0..2).map(|i| run_shard(&s, &o, i, 2).unwrap()).collect(), o)
}

fn refusal(parts: &[Partial]) -> String {
    match merge(parts) {
        Ok(_) => panic!("a damaged part was merged"),
        Err(e) => e.to_string(),
    }
}

/// Apply `edit` to part 2, with and without resealing the checksum: the
/// unsealed edit fails the checksum, the resealed one the content checks.
fn both(edit: impl Fn(&mut Partial), expect: &str) {
    let (p, _) = parts();
    let mut bad = p[1].clone();
    edit(&mut bad);
    let m = refusal(&[p[0].clone(), bad.clone()]);
    assert!(m.contains("part 2") && m.contains("checksum"), "{m}");
    let m = refusal(&[p[0].clone(), bad.seal()]);
    assert!(m.contains("part 2") && m.contains(expect), "expected {expect:?}: {m}");
}

#[test]
fn intact_parts_merge() {
    let (p, _) = parts();
    assert!(merge(&p).is_ok());
}

#[test]
fn a_sum_changed_by_two_to_the_forty_is_refused() {
    both(|p| p.batches[0].channels[0].sums[0] += 2f64.powi(40), "eq. S1");
}

#[test]
fn nan_and_infinite_sums_are_refused() {
    both(|p| p.batches[0].channels[0].sums[2] = f64::NAN, "is NaN");
    both(|p| p.batches[0].channels[0].sums[8] = f64::INFINITY, "is inf");
}

#[test]
fn every_reflectance_set_to_100_is_refused() {
    // The case: R + A = 1.18 per photon.
    both(
        |p| {
            for b in &mut p.batches {
                b.channels[0].sums[0] = 100.0;
            }
        },
        "eq. S1",
    );
}

#[test]
fn negative_escapes_are_refused() {
    both(
        |p| {
            // Balance kept, R made negative: R -> -1, A -> A + 1 + R.
            let s = &mut p.batches[0].channels[0].sums;
            s[4] += s[0] + 1.0;
            s[0] = -1.0;
            s[1] = -1.0;
        },
        "negative",
    );
}

#[test]
fn huge_layer_counts_are_refused_without_allocating() {
    both(|p| p.channels[0].layers = 1_000_000_000_000_000, "layout");
    both(|p| p.channels[0].layers = usize::MAX, "layout");
}

#[test]
fn a_one_of_one_shard_with_zero_batches_is_refused() {
    let (p, o) = parts();
    let mut empty = p[0].clone();
    empty.shard_index = 0;
    empty.shard_count = 1;
    empty.batches.clear();
    let m = refusal(&[empty.seal()]);
    assert!(m.contains("batch(es) stored") || m.contains("layout"), "{m}");
    // Zero batches in the run.
    let mut none = p[0].clone();
    none.shard_count = 1;
    none.batch_count = 0;
    none.batches.clear();
    assert!(merge(&[none.seal()]).is_err());
    let _ = o;
}

#[test]
fn more_shards_than_batches_are_refused_at_run_and_at_merge() {
    let s = Scene::from_toml_str(SCENE).unwrap();
    let o = McOptions { samples: 4_000, ..Default::default() };
    let r = run_shard(&s, &o, 0, 1_000_000_000_000);
    assert!(matches!(r, Err(McError::TooManyShards { .. })), "{r:?}");
    let (p, _) = parts();
    let mut forged = p[0].clone();
    forged.shard_count = 1_000_000_000_000;
    let m = refusal(&[forged.seal()]);
    assert!(m.contains("shards <= batches"), "{m}");
}

#[test]
fn counters_and_batching_are_checked() {
    both(|p| p.batches[0].channels[0].capped = u64::MAX, "counters");
    both(|p| p.batch_size = 1, "batching");
    both(|p| p.batches[0].photons += 1, "is not batch");
}

#[test]
fn read_partial_refuses_non_files_and_junk() {
    let d = std::env::temp_dir().join(format!("km-shard-read-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let e = km_montecarlo::read_partial(&d).unwrap_err().to_string();
    assert!(e.contains("not a regular file"), "{e}");
    let junk = d.join("junk.json");
    std::fs::write(&junk, b"{\"format\": 1}").unwrap();
    let e = km_montecarlo::read_partial(&junk).unwrap_err().to_string();
    assert!(e.contains("junk.json") && e.contains("not a km shard file"), "{e}");
    let e = km_montecarlo::read_partial(std::path::Path::new("/dev/zero")).unwrap_err();
    assert!(e.to_string().contains("not a regular file"), "{e}");
    std::fs::remove_dir_all(&d).unwrap();
}
