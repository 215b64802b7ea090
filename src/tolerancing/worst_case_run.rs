//! The worst-case search run as a study: every batch of points goes through the runner
//! into `<study output>/worst-case/`, in parallel and resumable; the search is replayed
//! from the stored runs, so a resumed run asks for the same points and ends with the same
//! bits. The result is written to `worst-case.json` beside the runs.

use super::worst_case::{search, Batch, Evaluate, Found, OutputExtremes, Progress, Settings};
use crate::study::manifest::Manifest;
use crate::study::merge::collect;
use crate::study::runner::{self, RunOptions};
use crate::study::store::{self, Row};
use crate::study::Study;
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// What `worst-case.json` holds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct WorstCase {
    pub study: String,
    pub inputs: Vec<String>,
    /// The box searched, per input (SI).
    pub boxes: Vec<(f64, f64)>,
    /// Half-width in σ of the box of an unbounded input.
    pub sigmas: f64,
    pub outputs: Vec<String>,
    pub extremes: Vec<OutputExtremes>,
    pub runs: u64,
    pub failed_runs: u64,
}

impl WorstCase {
    pub fn load(dir: &Path) -> Result<Option<WorstCase>> {
        let p = dir.join("worst-case.json");
        match std::fs::read_to_string(&p) {
            Ok(t) => serde_json::from_str(&t)
                .map(Some)
                .with_context(|| format!("reading {}", p.display())),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(e).with_context(|| format!("reading {}", p.display())),
        }
    }
}

/// The directory of a study's worst-case runs.
pub fn directory(results: &Path) -> PathBuf {
    results.join("worst-case")
}

/// The box of each parameter.
pub fn boxes(study: &Study, sigmas: f64) -> Vec<(f64, f64)> {
    study
        .parameters
        .iter()
        .map(|p| p.tolerance_box(sigmas))
        .collect()
}

/// The stored runs, handed to the search batch by batch.
struct Stored {
    rows: HashMap<u64, Row>,
    error: Option<String>,
}

impl Evaluate for Stored {
    fn outputs(&mut self, batch: &Batch) -> Option<Vec<Vec<f64>>> {
        let mut y = Vec::with_capacity(batch.points.len());
        for (k, x) in batch.points.iter().enumerate() {
            let id = batch.first + k as u64;
            let row = self.rows.get(&id)?;
            let same = row
                .inputs
                .iter()
                .zip(x)
                .all(|(a, b)| a.to_bits() == b.to_bits());
            if !same || row.tag.as_ref().map(|t| t.batch) != Some(batch.number) {
                self.error = Some(format!(
                    "run {id} is stored with other inputs than the search asks for: the runs belong to another version of the study"
                ));
                return None;
            }
            y.push(row.outputs.clone());
        }
        Some(y)
    }
}

/// The study whose runs the search stores.
pub fn search_study(
    study: &Study,
    outputs: &[usize],
    settings: &Settings,
    sigmas: f64,
    out: PathBuf,
) -> Study {
    let d = study.parameters.len();
    let corners = if d <= super::worst_case::MAX_CORNER_INPUTS {
        (1u64 << d) + 1
    } else {
        2 * d as u64 + 1 + 2 * outputs.len() as u64
    };
    let polls = 2 * outputs.len() as u64 * settings.starts as u64 * 2 * d as u64;
    let names: Vec<&str> = outputs
        .iter()
        .map(|&k| study.outputs[k].name.as_str())
        .collect();
    study.for_search(
        "worst-case",
        &format!(
            "box ±{sigmas} σ for unbounded inputs, step tolerance {}, {} starts, outputs {}",
            settings.tolerance,
            settings.starts,
            names.join(", ")
        ),
        corners + polls * settings.max_steps,
        out,
    )
}

/// Runs (or resumes) the worst-case search of `study`'s outputs numbered `outputs` into
/// `opts.out`; `None` when a stop signal ended it (every finished run is saved).
pub fn run(
    study: &Study,
    outputs: &[usize],
    settings: &Settings,
    sigmas: f64,
    opts: &RunOptions,
) -> Result<Option<WorstCase>> {
    let runs_study = search_study(study, outputs, settings, sigmas, opts.out.clone());
    let boxes = boxes(study, sigmas);
    loop {
        let rows = if crate::study::manifest::path(&opts.out).exists() {
            Manifest::load(&opts.out)?.check_same_study(&runs_study.hash(), &opts.out)?;
            collect(&opts.out)?
                .1
                .rows
                .into_iter()
                .map(|r| (r.id, r))
                .collect()
        } else {
            HashMap::new()
        };
        let mut stored = Stored { rows, error: None };
        let progress = search(&boxes, outputs, settings, &mut stored);
        if let Some(e) = stored.error {
            bail!("{}: {e}", opts.out.display());
        }
        let batch = match progress {
            Progress::Done(found) => {
                return finish(study, outputs, boxes, sigmas, found, &opts.out).map(Some)
            }
            Progress::Needs(b) => b,
        };
        if opts.progress {
            eprintln!(
                "batch {}: {}{}, runs {}–{}",
                batch.number,
                batch.stage,
                if batch.step > 0 {
                    format!(" step {}", batch.step)
                } else {
                    String::new()
                },
                batch.first,
                batch.first + batch.points.len() as u64 - 1
            );
        }
        let first = batch.first;
        let row = |i: u64| {
            let mut r = runs_study.row_at(i, batch.points[(i - first) as usize].clone());
            r.tag = Some(store::Tag {
                batch: batch.number,
                stage: batch.stage.into(),
                level: batch.step,
                chain: None,
                margin: None,
            });
            r
        };
        let end = first + batch.points.len() as u64;
        let report = runner::run_rows(&runs_study, opts, (first, end), &row)?;
        if report.interrupted || opts.stop.load(std::sync::atomic::Ordering::Relaxed) {
            return Ok(None);
        }
    }
}

fn finish(
    study: &Study,
    outputs: &[usize],
    boxes: Vec<(f64, f64)>,
    sigmas: f64,
    found: Found,
    out: &Path,
) -> Result<WorstCase> {
    let wc = WorstCase {
        study: study.name.clone(),
        inputs: study.parameters.iter().map(|p| p.path.clone()).collect(),
        boxes,
        sigmas,
        outputs: outputs
            .iter()
            .map(|&k| study.outputs[k].name.clone())
            .collect(),
        extremes: found.outputs,
        runs: found.runs,
        failed_runs: found.failed_runs,
    };
    let path = out.join("worst-case.json");
    std::fs::write(&path, serde_json::to_string_pretty(&wc)? + "\n")
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(wc)
}
