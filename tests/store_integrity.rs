//! The result directory under damage and concurrent use: corrupted or foreign parts are
//! refused by name, an unrelated directory is never written into, different shard splits
//! exclude each other, a merge never replaces a fuller result, and suspect runs are
//! flagged.

mod common;

use common::scratch;
use mc_study::study::manifest::{lock_file, Manifest};
use mc_study::study::merge::{merge, status};
use mc_study::study::runner::{part_files, parts_dir, run, RunOptions, Shard};
use mc_study::study::store;
use mc_study::study::Study;
use std::path::{Path, PathBuf};

fn ishigami(n: u64) -> Study {
    let p = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/studies/ishigami/study.yaml"
    ));
    Study::load(p, Some(n)).unwrap()
}

fn options(out: &Path, rows: usize) -> RunOptions {
    let mut o = RunOptions::new(out.to_path_buf());
    o.progress = false;
    o.rows_per_part = rows;
    o
}

fn outputs(path: &Path) -> Vec<(u64, Vec<u64>)> {
    store::read(path)
        .unwrap()
        .rows
        .iter()
        .map(|r| (r.id, r.outputs.iter().map(|v| v.to_bits()).collect()))
        .collect()
}

/// `--out` naming a directory of other files is refused, and nothing in it changes.
#[test]
fn an_unrelated_directory_is_never_written_into() {
    let victim = scratch("integrity-victim");
    std::fs::write(victim.join("study.yaml"), "mine").unwrap();
    std::fs::write(victim.join("results.parquet"), "also mine").unwrap();
    let e = run(&ishigami(16), &options(&victim, 8)).unwrap_err();
    assert!(
        e.to_string().contains("holds no results of mc-study"),
        "{e}"
    );
    assert_eq!(
        std::fs::read_to_string(victim.join("study.yaml")).unwrap(),
        "mine"
    );
    let names: Vec<_> = std::fs::read_dir(&victim).unwrap().collect();
    assert_eq!(names.len(), 2, "something was written into the directory");
    // an empty directory, and the directory of an earlier run of the study, are fine
    let empty = scratch("integrity-empty");
    run(&ishigami(16), &options(&empty, 8)).unwrap();
    run(&ishigami(16), &options(&empty, 8)).unwrap();
    // as is one that holds only the scripts of `mc-study slurm`
    let slurm = scratch("integrity-slurm");
    std::fs::create_dir_all(slurm.join("slurm/logs")).unwrap();
    std::fs::write(slurm.join("slurm/array.sbatch"), "#!/bin/bash\n").unwrap();
    run(&ishigami(16), &options(&slurm, 8)).unwrap();
}

/// One byte flipped in a part: the run and the merge refuse it by name and say how to
/// recover; once it is deleted, the resumed run recomputes exactly its samples.
#[test]
fn a_corrupted_part_is_refused_by_name_and_recovered_by_deleting_it() {
    let out = scratch("integrity-corrupt");
    let reference = scratch("integrity-corrupt-reference");
    let study = ishigami(64);
    run(&study, &options(&out, 16)).unwrap();
    run(&study, &options(&reference, 64)).unwrap();
    merge(&reference, false).unwrap();
    let parts = part_files(&out).unwrap();
    assert_eq!(parts.len(), 4);
    let victim: PathBuf = parts[2].clone();
    let mut bytes = std::fs::read(&victim).unwrap();
    // a byte in the middle of the data pages: the file still parses as Parquet
    let at = bytes.len() / 3;
    bytes[at] ^= 0x01;
    std::fs::write(&victim, bytes).unwrap();
    for e in [
        run(&study, &options(&out, 16)).unwrap_err(),
        merge(&out, false).err().expect("refused"),
    ] {
        let e = e.to_string();
        assert!(
            e.contains(victim.file_name().unwrap().to_str().unwrap())
                && e.contains("Delete it and rerun"),
            "{e}"
        );
    }
    std::fs::remove_file(&victim).unwrap();
    let r = run(&study, &options(&out, 16)).unwrap();
    assert_eq!(r.done, 16);
    merge(&out, false).unwrap();
    assert_eq!(
        outputs(&out.join("results.parquet")),
        outputs(&reference.join("results.parquet"))
    );
}

/// A part holding sample ids the study does not have, or a sample twice with different
/// values, is refused.
#[test]
fn parts_with_foreign_ids_or_conflicting_duplicates_are_refused() {
    let out = scratch("integrity-ids");
    let study = ishigami(32);
    run(&study, &options(&out, 16)).unwrap();
    let parts = part_files(&out).unwrap();
    let t = store::read(&parts[0]).unwrap();

    // a copy of a row of part 0 with one value changed: that sample twice, disagreeing
    // (which samples part 0 holds depends on which worker finished first)
    let mut rows = t.rows.clone();
    rows[0].outputs[0] += 1.0;
    let copy = parts_dir(&out).join("part-0of1-000099.parquet");
    store::write(&copy, &t.columns, &rows[..1], &t.metadata).unwrap();
    let e = merge(&out, false).err().expect("refused").to_string();
    let twice = format!(
        "sample {} is stored twice with different values",
        rows[0].id
    );
    assert!(e.contains(&twice), "{e}");
    // the same row again is harmless
    store::write(&copy, &t.columns, &t.rows[..1], &t.metadata).unwrap();
    assert_eq!(merge(&out, false).unwrap().rows, 32);

    // sample 40 of a 32-sample study
    let mut rows = t.rows.clone();
    rows.truncate(1);
    rows[0].id = 40;
    store::write(&copy, &t.columns, &rows, &t.metadata).unwrap();
    let e = merge(&out, false).err().expect("refused").to_string();
    assert!(e.contains("holds sample 40") && e.contains("000099"), "{e}");
    let e = run(&study, &options(&out, 16)).unwrap_err().to_string();
    assert!(e.contains("holds sample 40"), "{e}");
}

/// While a shard of a 2-way split runs (its lock held), an unsharded run of the same
/// directory is refused, and `status` says the shard is running, not partial.
#[test]
fn different_shard_splits_exclude_each_other() {
    let out = scratch("integrity-splits");
    let study = ishigami(32);
    let mut o = options(&out, 4);
    o.shard = Shard { index: 0, count: 2 };
    run(&study, &o).unwrap();
    // shard 1/2 "runs": a process holds its lock
    let lock = lock_file(&parts_dir(&out).join(".shard-1of2.lock")).unwrap();
    lock.lock().unwrap();
    let e = run(&study, &options(&out, 4)).unwrap_err().to_string();
    assert!(
        e.contains("shard 1/2") && e.contains("another process"),
        "{e}"
    );
    let s = status(&out, Some(2)).unwrap().to_string();
    assert!(
        s.lines()
            .any(|l| l.starts_with("1/2") && l.ends_with("running")),
        "{s}"
    );
    // a running shard is not a complete one
    assert!(s.contains("shards still running: 1"), "{s}");
    assert!(!s.contains("all shards complete"), "{s}");
    lock.unlock().unwrap();
    let r = run(&study, &options(&out, 4)).unwrap();
    assert_eq!((r.skipped, r.done), (16, 16));
}

/// A merge of fewer samples never replaces a fuller result (a slow `--allow-partial`
/// merge finishing after the complete one).
#[test]
fn a_merge_never_replaces_a_more_complete_result() {
    let out = scratch("integrity-merge");
    let study = ishigami(32);
    run(&study, &options(&out, 8)).unwrap();
    merge(&out, false).unwrap();
    let before = std::fs::read(out.join("results.parquet")).unwrap();
    // the partial merge sees one part fewer
    let parts = part_files(&out).unwrap();
    let aside = out.join("aside.parquet");
    std::fs::rename(&parts[1], &aside).unwrap();
    let e = merge(&out, true).err().expect("refused").to_string();
    assert!(
        e.contains("already holds 32 samples, more than the 24"),
        "{e}"
    );
    assert_eq!(std::fs::read(out.join("results.parquet")).unwrap(), before);
    std::fs::rename(&aside, &parts[1]).unwrap();
    assert_eq!(Manifest::load(&out).unwrap().completed.count(), 32);
}

/// A run that goes through with a fault is `suspect`, with the reason, and counted in the
/// summary; `suspect: fail` makes it a failure. Here: bodies that overlap at the start,
/// named with their contact and the depth.
#[test]
fn runs_that_start_overlapped_are_suspect_or_failed_as_the_study_says() {
    let dir = scratch("integrity-suspect");
    std::fs::write(
        dir.join("scene.yaml"),
        "duration: 0.2 s\nbodies:\n  - { name: ball, mass: 1 kg, shape: { sphere: { radius: 0.1 m } }, position: [0, 0, 0.5 m] }\ncontacts:\n  - { name: floor, body: ball, shape: { sphere: { radius: 0.1 m } }, against: ground, against_shape: { plane: { point: [0, 0, 0], normal: [0, 0, 1] } }, e: 0 }\nprobes:\n  - { name: height, measure: { distance: { from: { body: ground, point: [0, 0, 0] }, to: { body: ball, point: [0, 0, 0] }, axis: [0, 0, 1] } } }\n",
    )
    .unwrap();
    let study = |policy: &str| {
        format!("name: s\nscene: scene.yaml\nsamples: 64\nseed: 3\n{policy}parameters:\n  - {{ path: bodies.ball.position.z, distribution: {{ uniform: {{ lower: 0.05 m, upper: 0.15 m }} }} }}\n")
    };
    std::fs::write(dir.join("keep.yaml"), study("")).unwrap();
    std::fs::write(dir.join("fail.yaml"), study("suspect: fail\n")).unwrap();
    for (file, fails) in [("keep.yaml", false), ("fail.yaml", true)] {
        let s = Study::load(&dir.join(file), None).unwrap();
        let out = dir.join(format!("out-{file}"));
        run(&s, &options(&out, 64)).unwrap();
        let m = merge(&out, false).unwrap();
        let t = store::read(&m.path).unwrap();
        let overlapped = t.rows.iter().filter(|r| r.inputs[0] < 0.1 - 1e-9).count() as u64;
        assert!(overlapped > 10 && overlapped < 54, "{overlapped}");
        for r in &t.rows {
            let started_inside = r.inputs[0] < 0.1 - 1e-9;
            let flagged = if fails {
                r.error.as_deref()
            } else {
                r.suspect.as_deref()
            };
            assert_eq!(flagged.is_some(), started_inside, "row {}: {r:?}", r.id);
            if let Some(why) = flagged {
                // the pair is named, and the depth is the written one
                let named = "bodies overlapped at the start: `ball` and `ground`, contact `floor`";
                assert!(why.contains(named), "{why}");
                let depth = format!("(by {:.3e} m)", 0.1 - r.inputs[0]);
                assert!(why.contains(&depth), "{why} lacks {depth}");
            }
        }
        if fails {
            assert_eq!((m.summary.failed, m.summary.suspect), (overlapped, 0));
        } else {
            assert_eq!((m.summary.failed, m.summary.suspect), (0, overlapped));
            assert!(m.summary.to_string().contains(&format!(
                "suspect ×{overlapped}: bodies overlapped at the start: `ball` and `ground`, contact `floor`"
            )));
        }
    }
}

/// The summary's limits come from the study stored in the parts (which the hash covers),
/// not from the editable copy OUT/study.yaml: editing it changes no count.
#[test]
fn edited_copies_of_the_study_do_not_change_the_summary() {
    let out = scratch("integrity-limits");
    let dir = scratch("integrity-limits-study");
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/studies/ishigami/study.yaml"
    ))
    .unwrap()
    .replace(
        "scene: scene.yaml",
        &format!(
            "scene: {}/studies/ishigami/scene.yaml",
            env!("CARGO_MANIFEST_DIR")
        ),
    ) + "limits:\n  - { output: y, upper: 5 }\n";
    std::fs::write(dir.join("study.yaml"), &text).unwrap();
    let study = Study::load(&dir.join("study.yaml"), Some(64)).unwrap();
    run(&study, &options(&out, 64)).unwrap();
    let count = |m: &mc_study::study::merge::Merged| {
        m.summary.outputs[0].out_of_spec.as_ref().unwrap().count
    };
    let before = count(&merge(&out, false).unwrap());
    assert!(before > 5, "{before} samples above the limit");
    std::fs::write(
        out.join("study.yaml"),
        text.replace("upper: 5", "upper: 500"),
    )
    .unwrap();
    assert_eq!(count(&merge(&out, false).unwrap()), before);
}

/// `simulate` names an overlap at t = 0 (the pair and the depth) before its diagnostics; a
/// scene that starts clear reports none.
#[test]
fn simulate_names_bodies_that_start_overlapped() {
    use mc_study::scene::Scene;
    use mc_study::single_run::{simulate, SimulateOptions};
    let scene = |z: &str| {
        Scene::from_yaml(
            &format!("duration: 0.01 s\nbodies:\n  - {{ name: ball, mass: 1 kg, shape: {{ sphere: {{ radius: 0.1 m }} }}, position: [0, 0, {z}] }}\ncontacts:\n  - {{ name: floor, body: ball, shape: {{ sphere: {{ radius: 0.1 m }} }}, against: ground, against_shape: {{ plane: {{ point: [0, 0, 0], normal: [0, 0, 1] }} }}, e: 0 }}\n"),
            "overlap.yaml",
        )
        .unwrap()
    };
    let options = SimulateOptions {
        duration: None,
        trajectory: None,
        drawing: None,
    };
    let report = simulate(&scene("0.0915 m"), "overlap.yaml", &options).unwrap();
    let (what, depth) = report.overlap.clone().expect("the overlap is named");
    assert_eq!(what, "`ball` and `ground`, contact `floor`");
    assert!((depth - 8.5e-3).abs() < 1e-12, "{depth}");
    let text = report.to_string();
    assert!(
        text.contains(
            "overlap          at t = 0: `ball` and `ground`, contact `floor`, by 8.500e-3 m"
        ),
        "{text}"
    );
    let clear = simulate(&scene("0.5 m"), "clear.yaml", &options).unwrap();
    assert_eq!(clear.overlap, None);
    assert!(!clear.to_string().contains("overlap "));
}
