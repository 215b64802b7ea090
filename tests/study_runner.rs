//! The study runner end to end: determinism across threads and shards, crash safety under
//! SIGKILL, refusal of another study's directory, failed samples kept as rows.

mod common;

use common::{scratch, study_path};
use mc_study::study::merge::merge;
use mc_study::study::runner::{run, RunOptions, Shard};
use mc_study::study::store::{self, Row};
use mc_study::study::Study;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

fn bouncing_ball(n: u64) -> Study {
    bouncing_ball_of("study.yaml", n)
}

fn bouncing_ball_of(file: &str, n: u64) -> Study {
    Study::load(&study_path("bouncing-ball", file), Some(n)).unwrap_or_else(|e| panic!("{e}"))
}

fn options(out: &Path, threads: usize, shard: Shard) -> RunOptions {
    let mut o = RunOptions::new(out.to_path_buf());
    o.threads = Some(threads);
    o.shard = shard;
    o.progress = false;
    o.rows_per_part = 10;
    o
}

/// The rows of a results file with the wall time (the one non-reproducible column) zeroed.
fn results(out: &Path) -> (Vec<Row>, Vec<(String, String)>) {
    let t = store::read(&out.join("results.parquet")).unwrap();
    let mut meta: Vec<(String, String)> = t.metadata.into_iter().collect();
    meta.sort();
    let rows = t
        .rows
        .into_iter()
        .map(|mut r| {
            r.diagnostics.wall_ms = 0.0;
            r
        })
        .collect();
    (rows, meta)
}

#[test]
fn results_are_identical_whatever_the_threads_and_shards() {
    identical_whatever_the_threads_and_shards("study.yaml", "det");
}

/// The same under step control, whose step sequence each sample's state alone sets.
#[test]
fn adaptive_results_are_identical_whatever_the_threads_and_shards() {
    identical_whatever_the_threads_and_shards("study-adaptive.yaml", "det-adaptive");
}

fn identical_whatever_the_threads_and_shards(file: &str, name: &str) {
    let study = bouncing_ball_of(file, 40);
    let one = scratch(&format!("{name}-1-thread"));
    let two = scratch(&format!("{name}-2-threads"));
    let sharded = scratch(&format!("{name}-4-shards"));
    run(&study, &options(&one, 1, Shard::WHOLE)).unwrap();
    run(&study, &options(&two, 2, Shard::WHOLE)).unwrap();
    for index in [2, 0, 3, 1] {
        let r = run(&study, &options(&sharded, 2, Shard { index, count: 4 })).unwrap();
        assert_eq!(r.done, 10);
    }
    for out in [&one, &two, &sharded] {
        let m = merge(out, false).unwrap();
        assert_eq!(m.rows, 40);
    }
    let (a, meta_a) = results(&one);
    let (b, meta_b) = results(&two);
    let (c, meta_c) = results(&sharded);
    assert_eq!(a.len(), 40);
    assert!(a
        .iter()
        .enumerate()
        .all(|(i, r)| r.id == i as u64 && !r.failed()));
    // bit-identical: compare the f64 bit patterns, not approximate values
    let bits = |rows: &[Row]| -> Vec<Vec<u64>> {
        rows.iter()
            .map(|r| {
                r.inputs
                    .iter()
                    .chain(&r.outputs)
                    .map(|x| x.to_bits())
                    .collect()
            })
            .collect()
    };
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(bits(&a), bits(&c));
    assert_eq!(a, b);
    assert_eq!(a, c);
    assert_eq!(meta_a, meta_b);
    assert_eq!(meta_a, meta_c);
}

#[test]
fn a_shard_run_twice_does_no_sample_twice() {
    let study = bouncing_ball(12);
    let out = scratch("rerun-shard");
    let first = run(&study, &options(&out, 2, Shard { index: 1, count: 3 })).unwrap();
    assert_eq!((first.done, first.skipped), (4, 0));
    let again = run(&study, &options(&out, 2, Shard { index: 1, count: 3 })).unwrap();
    assert_eq!((again.done, again.skipped), (0, 4));
    // a whole run afterwards does only the other 8
    let whole = run(&study, &options(&out, 2, Shard::WHOLE)).unwrap();
    assert_eq!((whole.done, whole.skipped), (8, 4));
    assert!(whole.missing.is_empty());
    let err = merge(&scratch("empty-merge"), false).err().unwrap();
    assert!(err.to_string().contains("manifest.json"), "{err}");
}

#[test]
fn merge_names_the_missing_samples_and_allows_partial_on_request() {
    let study = bouncing_ball(12);
    let out = scratch("partial-merge");
    run(&study, &options(&out, 2, Shard { index: 0, count: 2 })).unwrap();
    let err = merge(&out, false).err().unwrap().to_string();
    assert!(err.contains("6 of 12 samples are missing: 6–11"), "{err}");
    assert!(!out.join("results.parquet").exists());
    let m = merge(&out, true).unwrap();
    assert_eq!((m.rows, m.missing.count()), (6, 6));
}

#[test]
fn another_studys_directory_is_refused_and_left_untouched() {
    let out = scratch("refuse-other-study");
    run(&bouncing_ball(6), &options(&out, 2, Shard::WHOLE)).unwrap();
    let listing = |d: &Path| -> Vec<(PathBuf, Vec<u8>)> {
        let mut v: Vec<(PathBuf, Vec<u8>)> = walk(d)
            .into_iter()
            .map(|p| (p.clone(), std::fs::read(&p).unwrap()))
            .collect();
        v.sort();
        v
    };
    let before = listing(&out);
    // same study, other sample count: another hash
    let err = run(&bouncing_ball(7), &options(&out, 2, Shard::WHOLE))
        .err()
        .unwrap()
        .to_string();
    assert!(
        err.contains("different study") && err.contains("Nothing was overwritten"),
        "{err}"
    );
    assert_eq!(before, listing(&out));
}

fn walk(d: &Path) -> Vec<PathBuf> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(d).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            v.extend(walk(&p));
        } else if !p.file_name().unwrap().to_string_lossy().starts_with('.') {
            v.push(p);
        }
    }
    v
}

#[test]
fn failed_samples_become_rows_with_their_reason_and_the_batch_goes_on() {
    let dir = scratch("failed-rows");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/linear.yaml");
    let study_file = dir.join("study.yaml");
    std::fs::write(
        &study_file,
        format!(
            "scene: {}\nsamples: 200\nseed: 3\nparameters:\n  - {{ path: inputs.x1, distribution: {{ normal: {{ mean: 0.5, sd: 1 }} }} }}\noutputs: [y, root]\n",
            scene.display()
        ),
    )
    .unwrap();
    let study = Study::load(&study_file, None).unwrap();
    let out = dir.join("out");
    let r = run(&study, &options(&out, 2, Shard::WHOLE)).unwrap();
    // P(x1 < 0) = Φ(−0.5) = 0.3085: about 62 of 200
    assert_eq!(r.done, 200);
    assert!((40..90).contains(&r.failed), "{} failed", r.failed);
    let m = merge(&out, false).unwrap();
    assert_eq!(m.rows, 200);
    assert_eq!(m.summary.failed, r.failed);
    assert_eq!(
        m.summary.failures,
        vec![("output `root` is NaN".to_string(), r.failed)]
    );
    let t = store::read(&m.path).unwrap();
    for row in &t.rows {
        assert_eq!(row.failed(), row.inputs[0] < 0.0, "row {}", row.id);
        if !row.failed() {
            assert_eq!(row.outputs[0], 3.0 * row.inputs[0] + 1.0);
        }
    }
}

/// SIGKILL, SIGTERM, SIGINT and SIGHUP at random moments (during sampling, part writes
/// and the final merge), then resume: exactly the samples of an uninterrupted run, none
/// lost and none written twice.
#[test]
fn killed_runs_resume_without_losing_or_repeating_a_sample() {
    killed_runs_resume("study.yaml", "sigkill", 320);
}

/// The same under step control (its samples take a thirtieth of the time: more of them).
#[test]
fn killed_adaptive_runs_resume_without_losing_or_repeating_a_sample() {
    killed_runs_resume("study-adaptive.yaml", "sigkill-adaptive", 8000);
}

fn killed_runs_resume(file: &str, name: &str, n: u64) {
    let exe = env!("CARGO_BIN_EXE_mc-study");
    let study = study_path("bouncing-ball", file);
    let out = scratch(name);
    let reference = scratch(&format!("{name}-reference"));
    let args = |o: &Path| -> Vec<String> {
        vec![
            "run".into(),
            study.display().to_string(),
            "--samples".into(),
            n.to_string(),
            "--out".into(),
            o.display().to_string(),
            "--threads".into(),
            "2".into(),
            "--part-rows".into(),
            "6".into(),
            "--quiet".into(),
        ]
    };
    // deterministic "random" kill delays (ms) from a fixed LCG
    let mut state: u64 = 0x2545_f491_4f6c_dd1d;
    let mut kills = 0;
    for round in 0..8 {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        let delay = 100 + (state >> 33) % 500;
        let signal = ["KILL", "TERM", "INT", "HUP"][round % 4];
        let mut child = Command::new(exe)
            .args(args(&out))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(delay));
        if child.try_wait().unwrap().is_none() {
            Command::new("kill")
                .args(["-s", signal, &child.id().to_string()])
                .status()
                .unwrap();
            kills += 1;
        }
        child.wait().unwrap();
    }
    assert!(kills >= 3, "only {kills} runs were still going when killed");
    let status = Command::new(exe)
        .args(args(&out))
        .stdout(Stdio::null())
        .status()
        .unwrap();
    assert!(status.success());
    let status = Command::new(exe)
        .args(args(&reference))
        .stdout(Stdio::null())
        .status()
        .unwrap();
    assert!(status.success());
    // every sample is in exactly one part
    let mut ids: Vec<u64> = Vec::new();
    for p in walk(&out.join("parts")) {
        ids.extend(store::read(&p).unwrap().rows.iter().map(|r| r.id));
    }
    ids.sort_unstable();
    assert_eq!(
        ids,
        (0..n).collect::<Vec<_>>(),
        "a sample lost or written twice"
    );
    assert_eq!(results(&out), results(&reference));
    println!("{kills} of 8 runs killed by a signal, then resumed: {n} samples, each in exactly one part, rows identical to an uninterrupted run");
}

/// SIGINT (Ctrl-C), SIGTERM (a scheduler's time limit or scancel) and SIGHUP stop starting
/// samples, write every finished one and exit with 128 + the signal's number; the manifest
/// records exactly the saved samples, so the same command resumes after them.
#[test]
fn stop_signals_write_the_samples_done_and_exit_with_128_plus_the_signal() {
    let exe = env!("CARGO_BIN_EXE_mc-study");
    let study = study_path("bouncing-ball", "study.yaml");
    for (signal, status) in [("INT", 130), ("TERM", 143), ("HUP", 129)] {
        let out = scratch(&format!("sig{signal}"));
        let args = [
            "run",
            study.to_str().unwrap(),
            "--samples",
            "100000",
            "--out",
            out.to_str().unwrap(),
            "--threads",
            "2",
            // parts too large to fill: only the flush on the signal writes
            "--part-rows",
            "1000000",
            "--part-seconds",
            "1000",
        ];
        let child = Command::new(exe)
            .args(args)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(700));
        let sent = Command::new("kill")
            .args(["-s", signal, &child.id().to_string()])
            .status()
            .unwrap();
        assert!(sent.success());
        let result = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(status), "SIG{signal}: {stderr}");
        assert!(
            stderr.contains(&format!("(SIG{signal})"))
                && stderr.contains("rerun the same command to resume"),
            "{stderr}"
        );
        let saved: usize = walk(&out.join("parts"))
            .iter()
            .map(|p| store::read(p).unwrap().rows.len())
            .sum();
        assert!(
            saved > 0 && saved < 100000,
            "SIG{signal}: {saved} samples saved"
        );
        let done: usize = stderr
            .lines()
            .find(|l| l.contains(" samples run ("))
            .and_then(|l| l.split_whitespace().next()?.parse().ok())
            .unwrap();
        assert_eq!(saved, done, "SIG{signal}: finished samples lost");
        let study = Study::load(&study, Some(100000)).unwrap();
        let manifest = mc_study::study::manifest::Manifest::load(&out).unwrap();
        assert_eq!(manifest.completed.count(), saved as u64);
        assert_eq!(manifest.study_hash, study.hash());
    }
}
