//! `mc-study compare` on two runs of the bouncing-ball study at two step sizes: the
//! differences it reports are those computed here from the stored rows, its verdict and
//! `--check` exit status follow the target, and a directory without results is named.

mod common;

use common::{scratch, stored_rows, study_path};
use mc_study::study::compare::compare;
use mc_study::study::statistics::sd;
use mc_study::study::store;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn mc_study(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mc-study"))
        .args(args)
        .output()
        .expect("mc-study runs")
}

/// The bouncing-ball study at step `h`, 24 samples, run into `dir/out-<tag>`.
fn run_at(dir: &Path, tag: &str, h: &str) -> PathBuf {
    let scene = study_path("bouncing-ball", "scene.yaml");
    let text = std::fs::read_to_string(study_path("bouncing-ball", "study.yaml"))
        .unwrap()
        .replace("scene: scene.yaml", &format!("scene: {}", scene.display()))
        .replace("h: 0.1 ms", &format!("h: {h}"));
    let study = dir.join(format!("study-{tag}.yaml"));
    std::fs::write(&study, text).unwrap();
    let out = dir.join(format!("out-{tag}"));
    let run = mc_study(&[
        "run",
        study.to_str().unwrap(),
        "--samples",
        "24",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    out
}

#[test]
fn compare_reports_the_differences_of_the_stored_rows_in_units_of_sigma() {
    let dir = scratch("compare");
    let fine = run_at(&dir, "fine", "0.1 ms");
    let coarse = run_at(&dir, "coarse", "2 ms");
    let (f, c) = (fine.to_str().unwrap(), coarse.to_str().unwrap());

    // a run against itself: no difference anywhere, and --check passes
    let same = mc_study(&["compare", f, f, "--check"]);
    let text = String::from_utf8_lossy(&same.stdout);
    assert!(same.status.success(), "{text}");
    assert!(
        text.contains("every output within 1.000 % of σ on all 24 compared samples"),
        "{text}"
    );

    // the coarse run: the largest difference of each output is the one computed here
    let rows = |d: &Path| stored_rows(&d.join("results.parquet"));
    let (fine_rows, coarse_rows) = (rows(&fine), rows(&coarse));
    let read = |d: &Path| store::read(&d.join("results.parquet")).unwrap();
    let comparison = compare(&read(&fine), &read(&coarse), 0.01);
    assert_eq!(comparison.per_sample.len(), 24);
    for (k, o) in comparison.outputs.iter().enumerate() {
        let values: Vec<f64> = fine_rows.iter().map(|r| r.outputs[k]).collect();
        let sigma = sd(&values);
        let largest = fine_rows
            .iter()
            .zip(&coarse_rows)
            .map(|(a, b)| {
                assert_eq!(a.id, b.id);
                (b.outputs[k] - a.outputs[k]).abs() / sigma
            })
            .fold(0.0, f64::max);
        let (reported, _) = o.largest.unwrap();
        assert!(largest > 0.0, "{}: the step changes nothing", o.name);
        assert!(
            (reported - largest).abs() <= 1e-12 * largest,
            "{}: {reported} vs {largest}",
            o.name
        );
    }

    // with a target below the coarse step's differences, --check fails and names samples
    let off = mc_study(&["compare", f, c, "--target", "1e-9", "--check"]);
    let text = String::from_utf8_lossy(&off.stdout);
    assert_eq!(off.status.code(), Some(1), "{text}");
    assert!(text.contains("24 of 24 samples above"), "{text}");
    let csv = dir.join("differences.csv");
    let written = mc_study(&["compare", f, c, "--csv", csv.to_str().unwrap()]);
    assert!(written.status.success());
    assert_eq!(std::fs::read_to_string(&csv).unwrap().lines().count(), 25);

    // a directory without results is named, with what to do
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let missing = mc_study(&["compare", f, empty.to_str().unwrap()]);
    assert!(!missing.status.success());
    let e = String::from_utf8_lossy(&missing.stderr);
    assert!(e.contains("empty: no results.parquet"), "{e}");
}
