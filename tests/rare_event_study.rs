//! A rare-event study on the runner: the estimate, bit-identical across threads, shards
//! and a resume after a lost batch, every run a row with its batch, level, chain and
//! margin, and the policy for runs that fail.

mod common;

use common::scratch;
use mc_study::reliability::study::{run, Ended, Finished};
use mc_study::study::runner::{RunOptions, Shard};
use mc_study::study::store;
use mc_study::study::Study;
use std::path::Path;

fn stack_study(extra: &str) -> Study {
    let params: String = ["a", "b", "c", "d", "e", "f", "g"]
        .iter()
        .map(|p| {
            format!(
                "  - {{ path: inputs.{p}, distribution: {{ normal: {{ mean: 0, sd: 1 }} }} }}\n"
            )
        })
        .collect();
    let text = format!(
        "name: stack\nscene: stack.yaml\nsamples: 300\nseed: 3\nparameters:\n{params}limits:\n  - {{ output: gap, upper: 4.753 m }}\nreliability: {{ method: subset, target_cov: 0.1{extra} }}\n"
    );
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    Study::from_yaml(&text, "stack-study.yaml", &base, None).unwrap_or_else(|e| panic!("{e}"))
}

fn options(out: &Path, threads: usize, shard: Shard) -> RunOptions {
    let mut o = RunOptions::new(out.to_path_buf());
    o.threads = Some(threads);
    o.shard = shard;
    o.progress = false;
    o.rows_per_part = 1024;
    o
}

fn finished(e: Ended) -> Finished {
    match e {
        Ended::Done(f) => *f,
        _ => panic!("the study did not finish"),
    }
}

/// The rows of `out`'s results with the wall time zeroed.
fn rows(out: &Path) -> Vec<store::Row> {
    common::stored_rows(&out.join("results.parquet"))
}

#[test]
fn a_ppm_rate_through_the_store_is_the_same_whatever_the_split() {
    let study = stack_study("");
    let truth = 1.00210e-6;
    let one = scratch("rare-1-thread");
    let a = finished(run(&study, &options(&one, 1, Shard::WHOLE)).unwrap());
    let e = &a.estimate;
    assert!(e.interval.0 <= truth && truth <= e.interval.1, "{e:?}");
    assert!(e.cov <= 0.1 && e.stage == "importance", "{e:?}");
    assert!((e.beta - 4.753).abs() < 0.1);

    // two threads
    let two = scratch("rare-2-threads");
    let b = finished(run(&study, &options(&two, 2, Shard::WHOLE)).unwrap());
    assert_eq!(
        a.estimate.probability.to_bits(),
        b.estimate.probability.to_bits()
    );
    assert_eq!(rows(&one), rows(&two));

    // three shards, each run until the batch it holds is done, round-robin
    let sharded = scratch("rare-3-shards");
    let mut done = None;
    'outer: for _round in 0..200 {
        for index in [2, 0, 1] {
            match run(&study, &options(&sharded, 1, Shard { index, count: 3 })).unwrap() {
                Ended::Done(f) => {
                    done = Some(*f);
                    break 'outer;
                }
                Ended::ShardDone { .. } => {}
                Ended::Stopped => panic!("no stop was asked for"),
            }
        }
    }
    let c = done.expect("the sharded study finishes");
    assert_eq!(
        a.estimate.probability.to_bits(),
        c.estimate.probability.to_bits()
    );
    assert_eq!(rows(&one), rows(&sharded));

    // every run is a row with its batch, stage, level, chain and margin
    let r = rows(&one);
    assert_eq!(r.len() as u64, a.estimate.simulations);
    for row in &r {
        let t = row.tag.as_ref().expect("tagged");
        let m = t.margin.expect("margin in the merged results");
        // the margin is (U − y)/s, negative exactly where the gap exceeds its limit
        assert_eq!(m <= 0.0, row.outputs[0] >= 4.753, "{row:?}");
        assert_eq!(t.chain.is_some(), t.stage == "subset" && t.level > 0);
    }
    let summary = std::fs::read_to_string(one.join("summary.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&summary).unwrap();
    let p = json["reliability"]["estimate"]["probability"]
        .as_f64()
        .unwrap();
    assert_eq!(p.to_bits(), a.estimate.probability.to_bits());
}

#[test]
fn a_resume_after_lost_parts_gives_the_same_bits() {
    let study = stack_study("");
    let whole = scratch("rare-whole");
    let a = finished(run(&study, &options(&whole, 2, Shard::WHOLE)).unwrap());
    // a second directory, its run cut short: every part after the tenth is lost, as if
    // the process had been killed then, and the summary was never written
    let cut = scratch("rare-cut");
    finished(run(&study, &options(&cut, 2, Shard::WHOLE)).unwrap());
    let mut parts: Vec<_> = std::fs::read_dir(cut.join("parts"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "parquet"))
        .collect();
    parts.sort();
    assert!(parts.len() > 20, "{} parts", parts.len());
    for p in &parts[10..] {
        std::fs::remove_file(p).unwrap();
    }
    std::fs::remove_file(cut.join("summary.json")).unwrap();
    std::fs::remove_file(cut.join("results.parquet")).unwrap();
    let b = finished(run(&study, &options(&cut, 1, Shard::WHOLE)).unwrap());
    assert_eq!(
        a.estimate.probability.to_bits(),
        b.estimate.probability.to_bits()
    );
    assert_eq!(rows(&whole), rows(&cut));
}

#[test]
fn stored_rows_of_another_study_are_refused() {
    let out = scratch("rare-other");
    finished(run(&stack_study(""), &options(&out, 2, Shard::WHOLE)).unwrap());
    // the same directory, another seed: the study hash differs, nothing is mixed
    let other = stack_study("").text.replace("seed: 3", "seed: 4");
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let other = Study::from_yaml(&other, "other.yaml", &base, None).unwrap();
    let err = run(&other, &options(&out, 2, Shard::WHOLE)).err().unwrap();
    let err = format!("{err:#}");
    assert!(
        err.contains("another study") || err.contains("hash"),
        "{err}"
    );
}

#[test]
fn the_reliability_block_is_checked_where_it_is_written() {
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let bad = |extra: &str, limits: bool, design: &str| {
        let text = format!(
            "name: s\nscene: stack.yaml\nsamples: 300\n{design}parameters:\n  - {{ path: inputs.a, distribution: {{ normal: {{ mean: 0, sd: 1 }} }} }}\n{}reliability: {{ {extra} }}\n",
            if limits { "limits:\n  - { output: gap, upper: 4 m }\n" } else { "" }
        );
        Study::from_yaml(&text, "s.yaml", &base, None)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default()
    };
    let e = bad("method: form", true, "");
    assert!(
        e.contains("reliability.method") && e.contains("unknown method"),
        "{e}"
    );
    let e = bad("method: subset", false, "");
    assert!(e.contains("gives no `limits`"), "{e}");
    let e = bad("target_cov: -1", true, "");
    assert!(e.contains("reliability.target_cov"), "{e}");
    let e = bad("output: nothing", true, "");
    assert!(
        e.contains("reliability.output") && e.contains("not among"),
        "{e}"
    );
    let e = bad("failed_samples: maybe", true, "");
    assert!(
        e.contains("failed_samples") && e.contains("fail, pass or error"),
        "{e}"
    );
    let e = bad("p0: 0.3", true, "");
    assert!(e.contains("samples") && e.contains("whole numbers"), "{e}");
    let e = bad("method: subset", true, "design: lhs\n");
    assert!(
        e.contains("design") && e.contains("draws its own samples"),
        "{e}"
    );
    // every error names the study file and a line
    assert!(e.contains("s.yaml:4"), "{e}");
}

fn fragile_study(policy: &str) -> Study {
    let text = format!(
        "name: fragile\nscene: fragile.yaml\nsamples: 500\nseed: 11\nparameters:\n  - {{ path: inputs.a, distribution: {{ normal: {{ mean: 0, sd: 1 }} }} }}\n  - {{ path: inputs.b, distribution: {{ normal: {{ mean: 0, sd: 1 }} }} }}\nlimits:\n  - {{ output: gap, upper: 6 }}\nreliability: {{ output: gap, failed_samples: {policy} }}\n"
    );
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    Study::from_yaml(&text, "fragile.yaml", &base, None).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn failed_runs_count_as_the_study_says() {
    // counted as failures (the default), they are the event: P ≈ Φ(−4) = 3.17e-5
    let out = scratch("rare-fragile-fail");
    let f = finished(run(&fragile_study("fail"), &options(&out, 2, Shard::WHOLE)).unwrap());
    let e = &f.estimate;
    assert!(f.summary.failed_runs > 0);
    assert!(
        (e.probability / 3.167e-5 - 1.0).abs() < 0.5,
        "{:e} against 3.167e-5",
        e.probability
    );
    // counted as passes, only the gap's own tail is left: 9.9e-10
    let out = scratch("rare-fragile-pass");
    let f = finished(run(&fragile_study("pass"), &options(&out, 2, Shard::WHOLE)).unwrap());
    assert!(
        f.estimate.probability < 1e-8,
        "{:e}",
        f.estimate.probability
    );
    // or the study stops and names the run
    let out = scratch("rare-fragile-error");
    let err = run(&fragile_study("error"), &options(&out, 2, Shard::WHOLE))
        .err()
        .map(|e| format!("{e:#}"))
        .unwrap_or_default();
    assert!(
        err.contains("failed") && err.contains("failed_samples: error"),
        "{err}"
    );
}

#[test]
fn killed_mid_level_and_rerun_the_cli_gives_the_same_bits() {
    use std::process::{Command, Stdio};
    let exe = env!("CARGO_BIN_EXE_mc-study");
    let study = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/stack-study.yaml");
    let whole = scratch("rare-cli-whole");
    let killed = scratch("rare-cli-killed");
    let run_to = |out: &Path| {
        Command::new(exe)
            .args([
                "run",
                study.to_str().unwrap(),
                "--quiet",
                "--part-rows",
                "8",
                "--out",
            ])
            .arg(out)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap()
    };
    assert!(run_to(&whole).wait().unwrap().success());
    // SIGKILL once a few dozen parts are written: in the middle of a subset level
    let mut child = run_to(&killed);
    let parts = killed.join("parts");
    loop {
        let n = std::fs::read_dir(&parts).map(|d| d.count()).unwrap_or(0);
        if n >= 40 {
            break;
        }
        if child.try_wait().unwrap().is_some() {
            panic!("the run ended before it could be killed");
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(!killed.join("summary.json").exists());
    assert!(run_to(&killed).wait().unwrap().success());
    assert_eq!(rows(&whole), rows(&killed));
    let p = |out: &Path| {
        let s = std::fs::read_to_string(out.join("summary.json")).unwrap();
        let v: serde_json::Value = serde_json::from_str(&s).unwrap();
        v["reliability"]["estimate"]["probability"]
            .as_f64()
            .unwrap()
            .to_bits()
    };
    assert_eq!(p(&whole), p(&killed));
}

#[test]
fn status_merge_and_report_read_a_rare_event_directory() {
    use std::process::Command;
    let exe = env!("CARGO_BIN_EXE_mc-study");
    let out = scratch("rare-cli-commands");
    let study = stack_study("");
    finished(run(&study, &options(&out, 2, Shard::WHOLE)).unwrap());
    let cli = |args: &[&str]| {
        let o = Command::new(exe).args(args).arg(&out).output().unwrap();
        assert!(
            o.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        String::from_utf8_lossy(&o.stdout).to_string()
    };
    let status = cli(&["status"]);
    assert!(status.contains("finished: P = 9.9"), "{status}");
    // a merge writes the same results and prints the estimate
    let before = rows(&out);
    std::fs::remove_file(out.join("results.parquet")).unwrap();
    let merged = cli(&["merge"]);
    assert!(
        merged.contains("P(failure) = 9.9") && merged.contains("β = 4.7"),
        "{merged}"
    );
    assert_eq!(before, rows(&out));
    // the report: the estimate, the levels, the tail and the drivers
    cli(&["report"]);
    let html = std::fs::read_to_string(out.join("report/report.html")).unwrap();
    for s in [
        "P(failure)",
        "95 % interval",
        "Subset simulation",
        "Most probable failure",
        "<svg",
    ] {
        assert!(html.contains(s), "the report lacks `{s}`");
    }
    for f in ["tail.svg", "tail.png", "drivers.svg", "drivers.png"] {
        assert!(out.join("report/figures").join(f).exists(), "{f}");
    }
    // with the later batches lost, status names the batch under way, and merge refuses
    let mut parts: Vec<_> = std::fs::read_dir(out.join("parts"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "parquet"))
        .collect();
    parts.sort();
    for p in &parts[5..] {
        std::fs::remove_file(p).unwrap();
    }
    let status = cli(&["status"]);
    assert!(status.contains("under way: batch 5"), "{status}");
    let o = Command::new(exe).arg("merge").arg(&out).output().unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("is not finished"));
}
