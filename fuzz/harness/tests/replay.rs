//! Every file of each fuzz target's corpus (`fuzz/corpus/<target>/`) and of the crashes the
//! fuzzers found (`fuzz/regressions/<target>/`, kept after the fix) runs through its target here,
//! on stable, in every test run.

use std::path::{Path, PathBuf};

fn inputs(kind: &str, target: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(kind)
        .join(target);
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
}

fn replay(kind: &str) -> usize {
    let mut n = 0;
    for target in fringe_fuzz::TARGETS {
        for path in inputs(kind, target.name) {
            let bytes = std::fs::read(&path)
                .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
            eprintln!("{} {}", target.name, path.display());
            (target.run)(&bytes);
            n += 1;
        }
    }
    n
}

#[test]
fn every_target_has_a_seed_corpus_and_runs_it_without_panicking() {
    for target in fringe_fuzz::TARGETS {
        assert!(
            !inputs("corpus", target.name).is_empty(),
            "fuzz target {} has no seed corpus in fuzz/corpus/{}",
            target.name,
            target.name
        );
    }
    assert!(replay("corpus") >= fringe_fuzz::TARGETS.len());
}

#[test]
fn every_crash_the_fuzzers_found_stays_fixed() {
    replay("regressions");
}

#[test]
fn targets_are_named_once_and_found_by_name() {
    for (i, t) in fringe_fuzz::TARGETS.iter().enumerate() {
        assert!(
            fringe_fuzz::TARGETS[..i].iter().all(|u| u.name != t.name),
            "{} twice",
            t.name
        );
        assert!(std::ptr::eq(fringe_fuzz::target(t.name).expect("found"), t));
    }
    assert!(fringe_fuzz::target("no such target").is_none());
}
