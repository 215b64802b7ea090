//! A rare-event study on the study runner. The margin of a run is the scaled distance of
//! its outputs to their limits, the smallest over the outputs that define failure:
//! (U − y)/s for an upper limit, (y − L)/s for a lower one, s the output's standard
//! deviation over the first batch. Each batch the algorithm asks for runs as a shard-able,
//! resumable set of rows in the store; the algorithm is replayed from the stored rows, so a
//! killed, resumed or sharded study asks for the same batches and ends with the same bits.

use super::batch::{Margins, Request, Tag};
use super::{run as estimate, Estimate, Method, Progress, Settings};
use crate::study::manifest::Manifest;
use crate::study::merge::collect;
use crate::study::runner::{self, RunOptions};
use crate::study::store::{self, Row};
use crate::study::{FailedSamples, RareEvent, Study};
use anyhow::{bail, Context, Result};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

impl RareEvent {
    /// The estimator's settings for a study of `samples` per level and seed `seed`.
    pub fn settings(&self, samples: u64, seed: u64) -> Settings {
        let method = if self.method == "subset" {
            Method::Subset
        } else {
            Method::MonteCarlo
        };
        Settings {
            p0: self.p0,
            importance: self.importance,
            max_simulations: self.max_simulations,
            ..Settings::new(method, samples as usize, self.target_cov, seed)
        }
    }
}

/// The margins of stored rows, scaled by the first batch's spread.
pub struct Stored<'a> {
    study: &'a Study,
    rare: &'a RareEvent,
    rows: HashMap<u64, Row>,
    scales: Option<Vec<f64>>,
    /// The standard-normal point of every run asked for, by id.
    points: HashMap<u64, Vec<f64>>,
    /// A stored row that does not belong to this replay, or a failure the study refuses.
    error: Option<String>,
}

impl Stored<'_> {
    /// One scale per output: its standard deviation over `rows`' values, or the size of
    /// its limits where it does not vary.
    fn scales(&self, rows: &[&Row]) -> Vec<f64> {
        self.study
            .outputs
            .iter()
            .enumerate()
            .map(|(k, o)| {
                let v: Vec<f64> = rows
                    .iter()
                    .map(|r| r.outputs[k])
                    .filter(|x| x.is_finite())
                    .collect();
                let sd = crate::study::statistics::sd(&v);
                if sd.is_finite() && sd > 0.0 {
                    sd
                } else {
                    let size = o
                        .lower
                        .unwrap_or(0.0)
                        .abs()
                        .max(o.upper.unwrap_or(0.0).abs());
                    if size > 0.0 {
                        size
                    } else {
                        1.0
                    }
                }
            })
            .collect()
    }

    fn margin(&self, row: &Row, scales: &[f64]) -> Result<f64, String> {
        if row.failed() || self.rare.outputs.iter().any(|&k| row.outputs[k].is_nan()) {
            return match self.rare.failed_samples {
                FailedSamples::Fail => Ok(f64::NEG_INFINITY),
                FailedSamples::Pass => Ok(f64::INFINITY),
                FailedSamples::Error => Err(format!(
                    "run {} failed ({}), and the study says `failed_samples: error`",
                    row.id,
                    row.error.as_deref().unwrap_or("no output")
                )),
            };
        }
        Ok(self
            .rare
            .outputs
            .iter()
            .map(|&k| {
                let (o, y, s) = (&self.study.outputs[k], row.outputs[k], scales[k]);
                let up = o.upper.map_or(f64::INFINITY, |u| (u - y) / s);
                let low = o.lower.map_or(f64::INFINITY, |l| (y - l) / s);
                up.min(low)
            })
            .fold(f64::INFINITY, f64::min))
    }
}

impl Margins for Stored<'_> {
    fn of(&mut self, request: &Request) -> Option<Vec<f64>> {
        for (k, u) in request.points.iter().enumerate() {
            self.points.insert(request.first + k as u64, u.clone());
        }
        let ids = request.first..request.first + request.points.len() as u64;
        let rows: Vec<&Row> = ids
            .clone()
            .map(|i| self.rows.get(&i))
            .collect::<Option<_>>()?;
        for ((row, u), tag) in rows.iter().zip(&request.points).zip(&request.tags) {
            let x = self.study.inputs_at_standard(u);
            let same = x
                .iter()
                .zip(&row.inputs)
                .all(|(a, b)| a.to_bits() == b.to_bits());
            if !same || row.tag.as_ref().map(|t| t.batch) != Some(tag.batch) {
                self.error = Some(format!(
                    "run {} is stored with other inputs or another batch than this study draws for it: the results belong to another version of the study",
                    row.id
                ));
                return None;
            }
        }
        if self.scales.is_none() {
            self.scales = Some(self.scales(&rows));
        }
        let scales = self.scales.clone().expect("set");
        let mut m = Vec::with_capacity(rows.len());
        for r in rows {
            match self.margin(r, &scales) {
                Ok(g) => m.push(g),
                Err(e) => {
                    self.error = Some(e);
                    return None;
                }
            }
        }
        Some(m)
    }
}

/// How a call of [`run`] ended.
pub enum Ended {
    Done(Box<Finished>),
    /// This shard's part of the current batch is stored; the others are still to run.
    ShardDone {
        batch: u64,
        remaining: u64,
    },
    /// A stop signal came; every finished run is stored.
    Stopped,
}

/// A finished rare-event study.
pub struct Finished {
    pub estimate: Estimate,
    pub summary: RareEventSummary,
    pub results: PathBuf,
}

/// The design point in the inputs' units, with the outputs it gives.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PointOfFailure {
    pub run: u64,
    /// (parameter, value in SI, shift from the median in standard deviations).
    pub inputs: Vec<(String, f64, f64)>,
    /// (output, value in SI).
    pub outputs: Vec<(String, f64)>,
}

/// What `summary.json` holds for a rare-event study.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RareEventSummary {
    pub study: String,
    /// The event: which outputs, and their limits.
    pub event: Vec<(String, Option<f64>, Option<f64>)>,
    pub estimate: Estimate,
    /// Runs whose simulation failed, and what they counted as.
    pub failed_runs: u64,
    pub failed_samples: String,
    pub most_probable_failure: Option<PointOfFailure>,
}

/// The rows stored in `out`, refusing another study's directory.
fn stored_rows(study: &Study, out: &Path) -> Result<HashMap<u64, Row>> {
    if !crate::study::manifest::path(out).exists() {
        return Ok(HashMap::new());
    }
    Manifest::load(out)?.check_same_study(&study.hash(), out)?;
    let (_, table) = collect(out)?;
    Ok(table.rows.into_iter().map(|r| (r.id, r)).collect())
}

/// Whether `out` holds a rare-event study's results (its rows carry batches and levels).
pub fn is_rare_event_dir(out: &Path) -> bool {
    Manifest::load(out).is_ok_and(|m| m.columns.tagged && m.design == "random")
}

/// The study stored with the results in `out`, and its rows by id, read once.
pub fn load(out: &Path) -> Result<(Study, HashMap<u64, Row>)> {
    let (manifest, table) = collect(out)?;
    let study = crate::study::merge::stored_study(&manifest, &table)?;
    Ok((study, table.rows.into_iter().map(|r| (r.id, r)).collect()))
}

/// The algorithm replayed on the rows stored in `out`: the estimate when the study is
/// done, or the batch it needs next.
pub fn replay<'a>(study: &'a Study, out: &Path) -> Result<(Progress, Stored<'a>)> {
    replay_rows(study, stored_rows(study, out)?, out)
}

/// The algorithm replayed on `rows`, the rows stored in `out`.
pub fn replay_rows<'a>(
    study: &'a Study,
    rows: HashMap<u64, Row>,
    out: &Path,
) -> Result<(Progress, Stored<'a>)> {
    let rare = study
        .reliability
        .as_ref()
        .context("the study has no `reliability` block")?;
    let settings = rare.settings(study.design.base, study.seed);
    let mut stored = Stored {
        study,
        rare,
        rows,
        scales: None,
        points: HashMap::new(),
        error: None,
    };
    let progress = estimate(&settings, study.parameters.len(), &mut stored);
    if let Some(e) = stored.error.take() {
        bail!("{}: {e}", out.display());
    }
    Ok((progress, stored))
}

/// Runs (or resumes) a rare-event study into `opts.out`, batch after batch.
pub fn run(study: &Study, opts: &RunOptions) -> Result<Ended> {
    loop {
        let (progress, stored) = replay(study, &opts.out)?;
        let request = match progress {
            Progress::Done(e) => return finish(study, *e, stored, &opts.out),
            Progress::Needs(r) => r,
        };
        let n = request.points.len() as u64;
        let tags: Vec<Tag> = request.tags.clone();
        let inputs: Vec<Vec<f64>> = request
            .points
            .iter()
            .map(|u| study.inputs_at_standard(u))
            .collect();
        let first = request.first;
        let row = |i: u64| {
            let k = (i - first) as usize;
            let mut r = study.row_at(i, inputs[k].clone());
            let t = &tags[k];
            r.tag = Some(store::Tag {
                batch: t.batch,
                stage: t.stage.name().into(),
                level: t.level,
                chain: t.chain,
                margin: None,
            });
            r
        };
        let batch = tags.first().map_or(0, |t| t.batch);
        if opts.progress {
            eprintln!(
                "batch {batch}: {} {}, runs {first}–{}",
                tags[0].stage.name(),
                if tags[0].stage == super::batch::Stage::Subset {
                    format!("level {}", tags[0].level)
                } else {
                    format!("round {}", tags[0].level)
                },
                first + n - 1
            );
        }
        let report = runner::run_rows(study, opts, (first, first + n), &row)?;
        if report.interrupted || opts.stop.load(std::sync::atomic::Ordering::Relaxed) {
            return Ok(Ended::Stopped);
        }
        if opts.shard.count > 1 {
            let mut told = false;
            loop {
                let m = Manifest::load(&opts.out)?;
                let remaining = m.completed.missing_in(first, first + n).count();
                if remaining == 0 {
                    break;
                }
                if !opts.wait_for_shards {
                    return Ok(Ended::ShardDone { batch, remaining });
                }
                if opts.stop.load(std::sync::atomic::Ordering::Relaxed) {
                    return Ok(Ended::Stopped);
                }
                if !told && opts.progress {
                    eprintln!(
                        "batch {batch}: waiting for the other shards ({remaining} runs left)"
                    );
                    told = true;
                }
                std::thread::sleep(std::time::Duration::from_millis(500));
            }
        }
    }
}

/// Writes `results.parquet` (every run with its margin) and `summary.json`.
fn finish(study: &Study, estimate: Estimate, stored: Stored, out: &Path) -> Result<Ended> {
    let summary = summarise(study, estimate.clone(), &stored)?;
    let mut rows = summary_rows(&stored, &estimate);
    rows.sort_by_key(|r| r.id);
    let results = out.join("results.parquet");
    store::write(&results, &study.columns(), &rows, &study.file_metadata())?;
    let json = serde_json::json!({ "reliability": summary });
    let path = out.join("summary.json");
    let tmp = out.join(format!(".summary.json.{}.tmp", std::process::id()));
    std::fs::write(&tmp, serde_json::to_string_pretty(&json)?)?;
    std::fs::rename(&tmp, &path)?;
    Ok(Ended::Done(Box::new(Finished {
        estimate,
        summary,
        results,
    })))
}

/// Every run of the estimate, with its margin.
pub fn summary_rows(stored: &Stored, estimate: &Estimate) -> Vec<Row> {
    let scales = stored.scales.clone().unwrap_or_default();
    let mut rows: Vec<Row> = stored
        .rows
        .values()
        .filter(|r| r.id < estimate.simulations)
        .cloned()
        .collect();
    rows.sort_by_key(|r| r.id);
    for r in &mut rows {
        let g = stored.margin(r, &scales).ok();
        if let Some(t) = r.tag.as_mut() {
            t.margin = g;
        }
    }
    rows
}

/// The summary of a finished estimate.
pub fn summarise(study: &Study, estimate: Estimate, stored: &Stored) -> Result<RareEventSummary> {
    let rare = stored.rare;
    let failed = stored
        .rows
        .values()
        .filter(|r| r.id < estimate.simulations && r.failed())
        .count() as u64;
    let most_probable_failure = estimate.design_point.as_ref().and_then(|dp| {
        let id = stored
            .points
            .iter()
            .filter(|(_, u)| u.iter().zip(&dp.u).all(|(a, b)| a.to_bits() == b.to_bits()))
            .map(|(id, _)| *id)
            .min()?;
        let row = stored.rows.get(&id)?;
        Some(PointOfFailure {
            run: id,
            inputs: study
                .parameters
                .iter()
                .zip(&row.inputs)
                .zip(&dp.u)
                .map(|((p, &x), &u)| (p.path.clone(), x, u))
                .collect(),
            outputs: study
                .outputs
                .iter()
                .zip(&row.outputs)
                .map(|(o, &y)| (o.name.clone(), y))
                .collect(),
        })
    });
    Ok(RareEventSummary {
        study: study.name.clone(),
        event: rare
            .outputs
            .iter()
            .map(|&k| {
                let o = &study.outputs[k];
                (o.name.clone(), o.lower, o.upper)
            })
            .collect(),
        estimate: estimate.clone(),
        failed_runs: failed,
        failed_samples: format!("{:?}", rare.failed_samples).to_lowercase(),
        most_probable_failure,
    })
}

/// Six significant digits, in plain notation where that is short.
fn number(x: f64) -> String {
    if x == 0.0 || (1e-2..1e5).contains(&x.abs()) {
        format!("{x:.6}")
    } else {
        format!("{x:.5e}")
    }
}

/// A unit as the printout shows it: "1" (a pure number) is left out.
fn shown(unit: &str) -> &str {
    if unit == "1" {
        ""
    } else {
        unit
    }
}

/// The printout of a finished rare-event study.
pub fn describe(f: &Finished, study: &Study) -> String {
    let e = &f.estimate;
    let s = &f.summary;
    let mut t = String::new();
    let event = s
        .event
        .iter()
        .map(|(n, l, u)| match (l, u) {
            (Some(l), Some(u)) => format!("{n} outside [{l}, {u}]"),
            (Some(l), None) => format!("{n} < {l}"),
            (None, Some(u)) => format!("{n} > {u}"),
            (None, None) => n.clone(),
        })
        .collect::<Vec<_>>()
        .join(" or ");
    t += &format!("rare event: {event}\n");
    if e.upper_bound {
        t += &format!(
            "  P(failure) < {:.3e} (upper bound; β > {:.2})\n",
            e.probability, e.beta
        );
    } else {
        t += &format!(
            "  P(failure) = {:.3e}  (CoV {:.3}, 95 % interval {:.3e} – {:.3e})\n",
            e.probability, e.cov, e.interval.0, e.interval.1
        );
        t += &format!(
            "  β = {:.3}  (95 % interval {:.3} – {:.3});  {:.2} ppm\n",
            e.beta,
            e.beta_interval.0,
            e.beta_interval.1,
            e.probability * 1e6
        );
    }
    t += &format!(
        "  {} simulations ({} failed, counted as `{}`); final figure from {}\n",
        e.simulations, s.failed_runs, s.failed_samples, e.stage
    );
    if let Some(sub) = &e.subset {
        t += &format!(
            "  subset simulation: {:.3e} (CoV {:.3}) over {} levels, {} simulations\n",
            sub.probability,
            sub.cov,
            sub.levels.len(),
            sub.simulations
        );
    }
    if let Some(is) = e.importance.as_ref().map(|i| &i.figures) {
        t += &format!(
            "  importance sampling: {:.3e} (CoV {:.3}), {} simulations, effective sample size {:.0}\n",
            is.probability, is.cov, is.simulations, is.ess
        );
    }
    if let Some(p) = &s.most_probable_failure {
        t += &format!("  most probable failure (run {}):\n", p.run);
        // inputs and outputs are listed in the study's order
        for ((name, x, u), q) in p.inputs.iter().zip(&study.parameters) {
            let unit = shown(&q.unit);
            t += &format!("    {name} = {} {unit} ({u:+.2} σ)\n", number(*x));
        }
        for ((name, y), o) in p.outputs.iter().zip(&study.outputs) {
            let unit = shown(&o.unit);
            t += &format!("    → {name} = {} {unit}\n", number(*y));
        }
    }
    for n in &e.notes {
        t += &format!("  note: {n}\n");
    }
    t
}

/// `mc-study merge` of a rare-event study: writes `results.parquet` and `summary.json` if
/// the last batch is done.
pub fn merge(out: &Path) -> Result<(Finished, Study)> {
    let (study, rows) = load(out)?;
    match replay_rows(&study, rows, out)? {
        (Progress::Done(e), stored) => match finish(&study, *e, stored, out)? {
            Ended::Done(f) => Ok((*f, study.clone())),
            _ => unreachable!("finish ends a study"),
        },
        (Progress::Needs(r), _) => bail!(
            "the rare-event study in {} is not finished: batch {} (runs {}–{}) is still to run. Rerun `mc-study run` on it (or its shards) to go on",
            out.display(),
            r.tags.first().map_or(0, |t| t.batch),
            r.first,
            r.first + r.points.len() as u64 - 1
        ),
    }
}

/// `mc-study status` of a rare-event study: the runs stored, and the batch under way.
pub fn status(out: &Path) -> Result<String> {
    let (study, rows) = load(out)?;
    let (progress, stored) = replay_rows(&study, rows, out)?;
    let mut t = format!(
        "rare-event study {} ({} method, {} samples per level, at most {} runs): {} runs stored\n",
        study.name,
        stored.rare.method,
        study.design.base,
        stored.rare.max_simulations,
        stored.rows.len()
    );
    match progress {
        Progress::Done(e) => {
            t += &format!(
                "finished: P = {:.3e} (CoV {:.3}) in {} runs; `mc-study merge {}` writes its results\n",
                e.probability,
                e.cov,
                e.simulations,
                out.display()
            );
        }
        Progress::Needs(r) => {
            let n = r.points.len() as u64;
            let done = (r.first..r.first + n)
                .filter(|i| stored.rows.contains_key(i))
                .count();
            let tag = r.tags[0];
            t += &format!(
                "under way: batch {} ({} level {}), runs {}–{}: {done} of {n} done\n",
                tag.batch,
                tag.stage.name(),
                tag.level,
                r.first,
                r.first + n - 1
            );
        }
    }
    Ok(t)
}
