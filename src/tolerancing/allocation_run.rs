//! `mc-study allocate` as rounds of studies: the study's own results are the first
//! round's samples; each round allocates on its samples (the linear stack-up, corrected by
//! reweighting), then runs the allocated study as its confirmation, whose samples serve
//! the next round if the target is missed. Every round is an ordinary study in
//! `<results>/allocation/round-N`, so it is parallel, resumable and deterministic.

use super::allocation::{cpk, cpk_interval, lagrange, weighted_moments, weights, MIN_ESS_SHARE};
use super::stack_up::stack_up;
use crate::study::merge::collect;
use crate::study::runner::{self, RunOptions};
use crate::study::store::Row;
use crate::study::tolerance::retoleranced_text;
use crate::study::{AllocationTarget, Study};
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};

/// Rounds at most (each one confirmation study).
pub const MAX_ROUNDS: usize = 3;

/// One output's Cpk in a confirmation study.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Confirmed {
    pub output: String,
    pub cpk: f64,
    /// Bissell's 95 % interval.
    pub interval: (f64, f64),
    pub samples: usize,
    pub out_of_spec: usize,
}

/// One round: the allocation on its samples and its confirmation.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Round {
    pub ratios: Vec<f64>,
    /// The Cpk the reweighted samples predict at the allocation, per target output.
    pub predicted: Vec<f64>,
    /// The effective sample size of that prediction, and the samples it came from.
    pub ess: f64,
    pub samples: usize,
    /// Too few effective samples: the prediction rests on the linear model alone.
    pub thin: bool,
    pub confirmed: Vec<Confirmed>,
    pub dir: PathBuf,
}

/// The allocation found.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Allocation {
    pub target: f64,
    pub ratios: Vec<f64>,
    pub cost_before: f64,
    pub cost_after: f64,
    pub rounds: Vec<Round>,
    /// The last confirmation agrees with the target for every output: the target lies
    /// below the upper end of each Cpk's 95 % interval. The allocation aims at the target
    /// itself, so its confirmation lands on it within the sampling error.
    pub met: bool,
    /// The study file with the allocated tolerances.
    pub file: PathBuf,
    /// Simulations run by the rounds (not counting the study's own).
    pub simulations: u64,
}

/// Why allocation stopped without an answer.
pub enum Ended {
    Done(Allocation),
    Stopped,
    /// No tolerances meet the target: output `output` misses it even at the narrowest.
    Infeasible {
        output: String,
        cpk_at_narrowest: f64,
    },
}

/// Runs `study` into `out` until complete; `false` when stopped.
fn complete(study: &Study, opts: &RunOptions, out: &Path) -> Result<Option<Vec<Row>>> {
    let mut o = opts.clone();
    o.out = out.to_path_buf();
    let r = runner::run(study, &o)?;
    if r.interrupted || !r.missing.is_empty() {
        return Ok(None);
    }
    let (_, table) = collect(out)?;
    Ok(Some(table.rows))
}

/// The allocation of `study` (read from `path`) for `target`, starting from its results in
/// `results` (run first if incomplete).
pub fn allocate(
    study: &Study,
    path: &Path,
    target: &AllocationTarget,
    results: &Path,
    opts: &RunOptions,
) -> Result<Ended> {
    let d = study.parameters.len();
    let toleranced: Vec<usize> = (0..d)
        .filter(|&i| study.parameters[i].drawing.is_some())
        .collect();
    if toleranced.is_empty() {
        bail!("{}: allocation changes tolerances written as `tolerance: {{ nominal, plus_minus, cp }}`, and the study has none", path.display());
    }
    if study.reliability.is_some() {
        bail!(
            "{}: allocate runs a plain study: drop the `reliability` block",
            path.display()
        );
    }
    let base = path.parent().unwrap_or(Path::new("."));
    let costs: Vec<_> = toleranced
        .iter()
        .map(|&i| study.parameters[i].cost)
        .collect();
    let bounds = (target.narrowest, target.widest);
    let outputs = &target.outputs;

    let Some(mut rows) = complete(study, opts, results)? else {
        return Ok(Ended::Stopped);
    };
    let mut from = vec![1.0; d];
    let mut rounds = Vec::new();
    let mut simulations = 0;
    let mut file_text = String::new();
    for round in 1..=MAX_ROUNDS {
        let ok: Vec<&Row> = rows.iter().filter(|r| !r.failed()).collect();
        let n = ok.len();
        let x: Vec<Vec<f64>> = (0..d)
            .map(|j| ok.iter().map(|r| r.inputs[j]).collect())
            .collect();
        let inputs: Vec<&[f64]> = ok.iter().map(|r| r.inputs.as_slice()).collect();
        // the linear model per target output at ratio 1
        let mut a = Vec::new();
        let mut budget = Vec::new();
        let mut rest = Vec::new();
        for &k in outputs {
            let o = &study.outputs[k];
            let y: Vec<f64> = ok.iter().map(|r| r.outputs[k]).collect();
            let st = stack_up(study, &o.name, &x, &y, crate::study::tolerance::BOX_SIGMAS)
                .with_context(|| {
                    format!(
                        "`{}`: too few samples or a constant output for a stack-up",
                        o.name
                    )
                })?;
            let sd0: Vec<f64> = toleranced
                .iter()
                .map(|&i| {
                    study.parameters[i]
                        .drawing
                        .as_ref()
                        .expect("toleranced")
                        .distribution()
                        .moments()
                        .1
                })
                .collect();
            let ak: Vec<f64> = toleranced
                .iter()
                .zip(&sd0)
                .map(|(&i, s)| (st.sensitivities[i] * s).powi(2))
                .collect();
            let (mean, sd) = weighted_moments(&vec![1.0 / n as f64; n], &y);
            let modelled: f64 = toleranced
                .iter()
                .zip(&ak)
                .map(|(&i, a)| a * from[i] * from[i])
                .sum();
            let r = (sd * sd - modelled).max(0.0);
            let s = cpk(mean, 1.0, o.lower, o.upper) / target.cpk;
            budget.push(s * s - r);
            rest.push(r);
            a.push(ak);
        }
        let solve = |budget: &[f64]| lagrange(&costs, &a, budget, bounds);
        let mut r_tol = match solve(&budget) {
            Ok(r) => r,
            Err(k) => {
                // the linear stack-up's Cpk with every tolerance at its narrowest
                let used: f64 = a[k].iter().map(|a| a * bounds.0 * bounds.0).sum();
                return Ok(Ended::Infeasible {
                    output: study.outputs[outputs[k]].name.clone(),
                    cpk_at_narrowest: target.cpk
                        * ((budget[k] + rest[k]) / (used + rest[k])).sqrt(),
                });
            }
        };
        // correct the budgets on the reweighted samples
        let mut predicted = Vec::new();
        let mut ess = 0.0;
        let mut thin = false;
        for _ in 0..30 {
            let to = expand(&toleranced, &r_tol, d);
            let (w, e) = weights(study, &from, &to, &inputs);
            // a uniform band wider than the one sampled has values no sample holds
            let covered = toleranced.iter().all(|&i| {
                study.parameters[i]
                    .drawing
                    .as_ref()
                    .is_some_and(|d| d.cp.is_some())
                    || to[i] <= from[i]
            });
            ess = if covered { e } else { 0.0 };
            predicted = outputs
                .iter()
                .map(|&k| {
                    let o = &study.outputs[k];
                    let y: Vec<f64> = ok.iter().map(|r| r.outputs[k]).collect();
                    let (m, s) = weighted_moments(&w, &y);
                    cpk(m, s, o.lower, o.upper)
                })
                .collect();
            if ess < MIN_ESS_SHARE * n as f64 {
                // the weights cannot tell: the linear model's own prediction
                thin = true;
                predicted = (0..outputs.len())
                    .map(|k| {
                        let used: f64 = (0..r_tol.len())
                            .map(|i| a[k][i] * r_tol[i] * r_tol[i])
                            .sum();
                        target.cpk * ((budget[k] + rest[k]) / (used + rest[k])).sqrt()
                    })
                    .collect();
                break;
            }
            let binding: Vec<bool> = (0..outputs.len())
                .map(|k| {
                    let used: f64 = (0..r_tol.len())
                        .map(|i| a[k][i] * r_tol[i] * r_tol[i])
                        .sum();
                    used >= budget[k] * (1.0 - 1e-6) || predicted[k] < target.cpk
                })
                .collect();
            let settled = (0..outputs.len()).all(|k| {
                let q = predicted[k] / target.cpk;
                if binding[k] {
                    (q - 1.0).abs() < 1e-3
                } else {
                    q >= 1.0
                }
            });
            if settled {
                break;
            }
            let mut next = budget.clone();
            for k in 0..outputs.len() {
                if binding[k] && predicted[k].is_finite() && predicted[k] > 0.0 {
                    next[k] *= (predicted[k] / target.cpk).powi(2);
                }
            }
            match solve(&next) {
                Ok(r) => {
                    budget = next;
                    r_tol = r;
                }
                Err(_) => break,
            }
        }
        file_text = retoleranced_text(
            &study.text,
            &study.name,
            &expand(&toleranced, &r_tol, d),
            "-allocated",
        )
        .map_err(|e| anyhow::anyhow!("{}: writing the allocated study: {e}", path.display()))?;
        let confirmation = Study::from_yaml(&file_text, &path.display().to_string(), base, None)
            .map_err(|e| anyhow::anyhow!("the allocated study does not load: {e}"))?;
        // the ratios as written (to four digits): those the confirmation samples
        let ratios: Vec<f64> = (0..d)
            .map(|i| {
                match (
                    &study.parameters[i].drawing,
                    &confirmation.parameters[i].drawing,
                ) {
                    (Some(a), Some(b)) => (b.plus + b.minus) / (a.plus + a.minus),
                    _ => 1.0,
                }
            })
            .collect();
        let dir = results.join("allocation").join(format!("round-{round}"));
        if opts.progress {
            eprintln!(
                "round {round}: allocated on {n} samples (ESS {ess:.0}{}); predicted Cpk {}; confirming with {} runs → {}",
                if thin { ", too thin: the linear model alone" } else { "" },
                predicted.iter().map(|c| format!("{c:.3}")).collect::<Vec<_>>().join(", "),
                confirmation.runs(),
                dir.display()
            );
        }
        let Some(new_rows) = complete(&confirmation, opts, &dir)? else {
            return Ok(Ended::Stopped);
        };
        simulations += new_rows.len() as u64;
        let confirmed: Vec<Confirmed> = outputs
            .iter()
            .map(|&k| {
                let o = &study.outputs[k];
                let y: Vec<f64> = new_rows
                    .iter()
                    .filter(|r| !r.failed())
                    .map(|r| r.outputs[k])
                    .collect();
                let m = y.len();
                let (mean, sd) = weighted_moments(&vec![1.0 / m as f64; m], &y);
                let sd = sd * (m as f64 / (m as f64 - 1.0)).sqrt();
                let c = cpk(mean, sd, o.lower, o.upper);
                let bad = new_rows
                    .iter()
                    .filter(|r| {
                        let v = r.outputs[k];
                        r.failed()
                            || o.lower.is_some_and(|l| v < l)
                            || o.upper.is_some_and(|u| v > u)
                    })
                    .count();
                Confirmed {
                    output: o.name.clone(),
                    cpk: c,
                    interval: cpk_interval(c, m),
                    samples: m,
                    out_of_spec: bad,
                }
            })
            .collect();
        let met = confirmed.iter().all(|c| c.interval.1 >= target.cpk);
        rounds.push(Round {
            ratios: ratios.clone(),
            predicted,
            ess,
            samples: n,
            thin,
            confirmed,
            dir,
        });
        // a round the weights could not check is refined on its confirmation's samples
        if (met && !thin) || round == MAX_ROUNDS {
            break;
        }
        rows = new_rows;
        from = ratios;
    }
    let last = rounds.last().expect("at least one round");
    let ratios = last.ratios.clone();
    let met = last.confirmed.iter().all(|c| c.interval.1 >= target.cpk);
    let file = allocated_path(path);
    std::fs::write(&file, &file_text).with_context(|| format!("writing {}", file.display()))?;
    let cost = |r: &[f64]| {
        toleranced
            .iter()
            .map(|&i| study.parameters[i].cost.at(r[i]))
            .sum::<f64>()
    };
    Ok(Ended::Done(Allocation {
        target: target.cpk,
        cost_before: cost(&vec![1.0; d]),
        cost_after: cost(&ratios),
        ratios,
        rounds,
        met,
        file,
        simulations,
    }))
}

/// Ratios per parameter: those of the toleranced ones, 1 for the others.
fn expand(toleranced: &[usize], r: &[f64], d: usize) -> Vec<f64> {
    let mut all = vec![1.0; d];
    for (&i, &v) in toleranced.iter().zip(r) {
        all[i] = v;
    }
    all
}

/// `study.yaml` → `study.allocated.yaml`, beside it.
pub fn allocated_path(path: &Path) -> PathBuf {
    let stem = path
        .file_stem()
        .map_or("study".into(), |s| s.to_string_lossy().into_owned());
    path.with_file_name(format!("{stem}.allocated.yaml"))
}
