//! `mc-study slurm` on a real Slurm: a 4-task array, one task cancelled mid-run, its index
//! resubmitted, the merge job run; the merged results equal a single-machine run. Tasks
//! stopped by scancel or by their time limit keep every sample they finished.
//! Runs when built with MC_STUDY_SLURM=1 (`.ci/run` starts the one-node cluster of
//! `ci/local-slurm` and sets it); otherwise it is reported as ignored.

mod common;

use common::{scratch, stored_rows as rows, study_path};
use mc_study::study::merge::merge;
use mc_study::study::runner::{run, RunOptions};
use mc_study::study::store;
use mc_study::study::Study;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

const SAMPLES: u64 = 800;

fn sh(cmd: &str, args: &[&str]) -> String {
    let out = Command::new(cmd)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("{cmd}: {e}"));
    assert!(
        out.status.success(),
        "{cmd} {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).to_string()
}

/// Waits until `squeue` lists none of `jobs` (finished, failed or cancelled).
fn wait_gone(jobs: &[&str], deadline: Instant) {
    loop {
        let q = sh("squeue", &["-h", "-o", "%i %T", "-j", &jobs.join(",")]);
        if q.trim().is_empty() {
            return;
        }
        assert!(Instant::now() < deadline, "jobs still queued:\n{q}");
        std::thread::sleep(Duration::from_millis(250));
    }
}

fn parts_of(out: &Path, label: &str) -> Vec<std::path::PathBuf> {
    std::fs::read_dir(out.join("parts"))
        .map(|d| {
            d.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| {
                    let n = p.file_name().unwrap().to_string_lossy().to_string();
                    n.starts_with(&format!("part-{label}-")) && n.ends_with(".parquet")
                })
                .collect()
        })
        .unwrap_or_default()
}

/// The array and merge job ids in what `mc-study slurm --submit` printed:
/// "submitted array job 12 (tasks 12_0 … 12_3) and merge job 13 (…)".
fn job_ids(printed: &str) -> (String, String) {
    let words: Vec<&str> = printed.split_whitespace().collect();
    let id_after = |x: &str, y: &str| -> String {
        let i = words
            .windows(2)
            .position(|w| w[0] == x && w[1] == y)
            .unwrap_or_else(|| panic!("{printed}"));
        words[i + 2].to_string()
    };
    let (job, merge_job) = (id_after("array", "job"), id_after("merge", "job"));
    assert!(
        job.chars().all(|c| c.is_ascii_digit()) && merge_job.chars().all(|c| c.is_ascii_digit()),
        "{printed}"
    );
    (job, merge_job)
}

#[test]
#[cfg_attr(
    not(slurm_cluster),
    ignore = "needs a Slurm cluster: `ci/local-slurm start`, then MC_STUDY_SLURM=1 cargo test (.ci/run does both)"
)]
fn job_array_with_a_cancelled_task_resubmitted_merges_to_the_single_machine_results() {
    let exe = env!("CARGO_BIN_EXE_mc-study");
    let study = study_path("bouncing-ball", "study.yaml");
    let out = scratch("slurm-array");
    let deadline = Instant::now() + Duration::from_secs(600);
    let n = SAMPLES.to_string();
    let printed = sh(
        exe,
        &[
            "slurm",
            study.to_str().unwrap(),
            "--tasks",
            "4",
            "--samples",
            &n,
            "--out",
            out.to_str().unwrap(),
            "--part-rows",
            "5",
            "--submit",
        ],
    );
    let (job, merge_job) = job_ids(&printed);

    // cancel task 3 once it has written at least one part, while it still has work to do
    let task = format!("{job}_3");
    loop {
        let written = parts_of(&out, "3of4").len();
        if written >= 1 {
            sh("scancel", &[&task]);
            break;
        }
        assert!(Instant::now() < deadline, "task {task} never wrote a part");
        std::thread::sleep(Duration::from_millis(20));
    }
    wait_gone(&[&job, &merge_job], deadline);

    // the merge job ran after every task ended and refused: shard 3 is incomplete
    let merge_log = std::fs::read_to_string(
        out.join("slurm/logs")
            .join(format!("merge-{merge_job}.out")),
    )
    .unwrap();
    assert!(merge_log.contains("samples are missing"), "{merge_log}");
    assert!(!out.join("results.parquet").exists());
    let status = sh(exe, &["status", out.to_str().unwrap()]);
    assert!(status.contains("--array=3"), "{status}");
    assert!(
        status
            .lines()
            .any(|l| l.starts_with("3/4") && l.ends_with("partial")),
        "{status}"
    );
    let before: usize = parts_of(&out, "3of4")
        .iter()
        .map(|p| store::read(p).unwrap().rows.len())
        .sum();
    assert!(
        before > 0 && (before as u64) < SAMPLES / 4,
        "task 3 saved {before} samples before cancellation"
    );

    // resubmit index 3 only, then the merge job after it
    let array = out.join("slurm/array.sbatch");
    let again = sh(
        "sbatch",
        &["--parsable", "--array=3", array.to_str().unwrap()],
    )
    .trim()
    .to_string();
    let merge_script = out.join("slurm/merge.sbatch");
    let merge2 = sh(
        "sbatch",
        &[
            "--parsable",
            &format!("--dependency=afterany:{again}"),
            merge_script.to_str().unwrap(),
        ],
    )
    .trim()
    .to_string();
    wait_gone(&[&again, &merge2], deadline);
    let log = std::fs::read_to_string(out.join("slurm/logs/task-3.out")).unwrap();
    assert!(
        log.contains(&format!("{before} already done")),
        "the resubmitted task did not resume:\n{log}"
    );

    // every sample in exactly one part, and the merged file equals a single-machine run
    let mut ids: Vec<u64> = Vec::new();
    for label in ["0of4", "1of4", "2of4", "3of4"] {
        for p in parts_of(&out, label) {
            ids.extend(store::read(&p).unwrap().rows.iter().map(|r| r.id));
        }
    }
    ids.sort_unstable();
    assert_eq!(ids, (0..SAMPLES).collect::<Vec<_>>());
    assert!(
        out.join("results.parquet").exists(),
        "the second merge job wrote no results"
    );
    let single = scratch("slurm-single-machine");
    let s = Study::load(&study, Some(SAMPLES)).unwrap();
    let mut o = RunOptions::new(single.clone());
    o.progress = false;
    run(&s, &o).unwrap();
    merge(&single, false).unwrap();
    assert_eq!(
        rows(&out.join("results.parquet")),
        rows(&single.join("results.parquet"))
    );
}

/// The samples a task's log says it ran before it stopped.
fn reported_done(log: &str) -> usize {
    let line = log
        .lines()
        .find(|l| l.contains(" samples run ("))
        .unwrap_or_else(|| panic!("no final line in the task log:\n{log}"));
    line.split_whitespace().next().unwrap().parse().unwrap()
}

#[test]
#[cfg_attr(
    not(slurm_cluster),
    ignore = "needs a Slurm cluster: `ci/local-slurm start`, then MC_STUDY_SLURM=1 cargo test (.ci/run does both)"
)]
fn tasks_stopped_by_scancel_or_their_time_limit_keep_every_finished_sample() {
    let exe = env!("CARGO_BIN_EXE_mc-study");
    let study = study_path("bouncing-ball", "study.yaml");
    let out = scratch("slurm-stopped");
    // far more samples than a minute holds, and parts so large that only the flush on the
    // signal writes them
    let printed = sh(
        exe,
        &[
            "slurm",
            study.to_str().unwrap(),
            "--tasks",
            "2",
            "--samples",
            "100000000",
            "--time",
            "1",
            "--out",
            out.to_str().unwrap(),
            "--part-rows",
            "1000000000",
            "--submit",
        ],
    );
    let (job, merge_job) = job_ids(&printed);
    let deadline = Instant::now() + Duration::from_secs(300);
    let log = |i: u64| {
        std::fs::read_to_string(out.join(format!("slurm/logs/task-{i}.out"))).unwrap_or_default()
    };
    // task 0 is cancelled once it has run a few seconds; task 1 runs into its time limit
    while !log(0).contains("shard 0/2") {
        assert!(Instant::now() < deadline, "task 0 never started");
        std::thread::sleep(Duration::from_millis(100));
    }
    std::thread::sleep(Duration::from_secs(3));
    sh("scancel", &[&format!("{job}_0")]);
    wait_gone(&[&job, &merge_job], deadline);

    let status = sh(exe, &["status", out.to_str().unwrap()]);
    for (i, label) in [(0, "0of2"), (1, "1of2")] {
        let log = log(i);
        assert!(log.contains("(SIGTERM)"), "task {i}:\n{log}");
        let saved: usize = parts_of(&out, label)
            .iter()
            .map(|p| store::read(p).unwrap().rows.len())
            .sum();
        assert!(saved > 0, "task {i} saved nothing:\n{log}");
        assert_eq!(saved, reported_done(&log), "task {i} lost samples:\n{log}");
        assert!(
            status
                .lines()
                .any(|l| l.starts_with(&format!("{i}/2")) && l.ends_with("partial")),
            "{status}"
        );
    }
}

#[test]
#[cfg_attr(
    not(slurm_cluster),
    ignore = "needs a Slurm cluster: `ci/local-slurm start`, then MC_STUDY_SLURM=1 cargo test (.ci/run does both)"
)]
fn a_rare_event_study_runs_as_one_array_whose_tasks_share_each_batch() {
    // every task runs its shard of each batch, waits for the others to finish the batch,
    // and goes on; the merge job then writes the estimate
    let exe = env!("CARGO_BIN_EXE_mc-study");
    let study = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/stack-study.yaml");
    let out = scratch("slurm-rare-event");
    let deadline = Instant::now() + Duration::from_secs(600);
    let printed = sh(
        exe,
        &[
            "slurm",
            study.to_str().unwrap(),
            "--tasks",
            "2",
            "--out",
            out.to_str().unwrap(),
            "--submit",
        ],
    );
    let (job, merge_job) = job_ids(&printed);
    wait_gone(&[&job, &merge_job], deadline);
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap_or_else(|e| {
        let log = std::fs::read_to_string(out.join(format!("slurm/logs/merge-{merge_job}.out")))
            .unwrap_or_default();
        panic!("no summary.json ({e}); merge log:\n{log}")
    });
    let json: serde_json::Value = serde_json::from_str(&summary).unwrap();
    let p = json["reliability"]["estimate"]["probability"]
        .as_f64()
        .unwrap();
    // both tasks stored rows of the same batches
    for label in ["0of2", "1of2"] {
        assert!(
            !parts_of(&out, label).is_empty(),
            "task {label} stored nothing"
        );
    }
    let single = scratch("slurm-rare-event-single");
    let s = Study::load(&study, None).unwrap();
    let mut o = RunOptions::new(single.clone());
    o.progress = false;
    let Ok(mc_study::reliability::study::Ended::Done(f)) =
        mc_study::reliability::study::run(&s, &o)
    else {
        panic!("the single-machine run did not finish")
    };
    assert_eq!(p.to_bits(), f.estimate.probability.to_bits());
    assert_eq!(rows(&out.join("results.parquet")), rows(&f.results));
}
