//! `OUT/summary.json` and the printed table: per output, count, failures, mean with its
//! 95 % interval, σ, range, quantiles, histogram, out-of-spec fraction (Wilson 95 %) and
//! Cp/Cpk; per input–output pair, Pearson and Spearman correlation.

use super::manifest::OutputLimits;
use super::statistics as st;
use super::store::Table;
use serde::Serialize;
use std::fmt::Write;

pub const QUANTILES: [f64; 5] = [0.01, 0.05, 0.5, 0.95, 0.99];

#[derive(Clone, Debug, Serialize)]
pub struct OutputSummary {
    pub name: String,
    pub unit: String,
    /// Successful samples.
    pub count: u64,
    pub failed: u64,
    pub mean: f64,
    pub mean_ci95: (f64, f64),
    pub sd: f64,
    pub min: f64,
    pub max: f64,
    /// (p, value) for p in 1, 5, 50, 95, 99 %.
    pub quantiles: Vec<(f64, f64)>,
    pub histogram: Histogram,
    pub lower_limit: Option<f64>,
    pub upper_limit: Option<f64>,
    pub out_of_spec: Option<OutOfSpec>,
    pub cp: Option<f64>,
    pub cpk: Option<f64>,
}

#[derive(Clone, Debug, Serialize)]
pub struct Histogram {
    pub lower: f64,
    pub width: f64,
    pub counts: Vec<u64>,
}

#[derive(Clone, Debug, Serialize)]
pub struct OutOfSpec {
    pub count: u64,
    pub fraction: f64,
    pub wilson95: (f64, f64),
}

#[derive(Clone, Debug, Serialize)]
pub struct Correlation {
    pub input: String,
    pub output: String,
    pub pearson: f64,
    pub spearman: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    pub study: String,
    pub samples: u64,
    pub failed: u64,
    pub outputs: Vec<OutputSummary>,
    pub correlations: Vec<Correlation>,
    /// Failure reasons (first line) with their counts, most frequent first.
    pub failures: Vec<(String, u64)>,
}

impl Summary {
    pub fn of(study: &str, table: &Table, limits: &[OutputLimits]) -> Summary {
        let ok: Vec<_> = table.rows.iter().filter(|r| !r.failed()).collect();
        let failed = table.rows.len() as u64 - ok.len() as u64;
        let mut outputs = Vec::new();
        for (k, (name, unit)) in table.columns.outputs.iter().enumerate() {
            let mut x: Vec<f64> = ok.iter().map(|r| r.outputs[k]).collect();
            x.sort_by(f64::total_cmp);
            let lim = limits.iter().find(|l| l.name == *name);
            let (lower, upper) = (lim.and_then(|l| l.lower), lim.and_then(|l| l.upper));
            let (mean, sd) = (st::mean(&x), st::sd(&x));
            let out_of_spec = (lower.is_some() || upper.is_some()).then(|| {
                let bad = x
                    .iter()
                    .filter(|&&v| lower.is_some_and(|l| v < l) || upper.is_some_and(|u| v > u))
                    .count() as u64;
                OutOfSpec {
                    count: bad,
                    fraction: bad as f64 / x.len().max(1) as f64,
                    wilson95: st::wilson95(bad, x.len() as u64),
                }
            });
            let (cp, cpk) = st::capability(mean, sd, lower, upper);
            let (hl, hw, counts) = st::histogram(&x);
            outputs.push(OutputSummary {
                name: name.clone(),
                unit: unit.clone(),
                count: x.len() as u64,
                failed,
                mean,
                mean_ci95: st::mean_ci95(&x),
                sd,
                min: x.first().copied().unwrap_or(f64::NAN),
                max: x.last().copied().unwrap_or(f64::NAN),
                quantiles: QUANTILES
                    .iter()
                    .map(|&p| (p, st::quantile_sorted(&x, p)))
                    .collect(),
                histogram: Histogram {
                    lower: hl,
                    width: hw,
                    counts,
                },
                lower_limit: lower,
                upper_limit: upper,
                out_of_spec,
                cp,
                cpk,
            });
        }
        let mut correlations = Vec::new();
        for (i, (input, _)) in table.columns.inputs.iter().enumerate() {
            let x: Vec<f64> = ok.iter().map(|r| r.inputs[i]).collect();
            for (k, (output, _)) in table.columns.outputs.iter().enumerate() {
                let y: Vec<f64> = ok.iter().map(|r| r.outputs[k]).collect();
                correlations.push(Correlation {
                    input: input.clone(),
                    output: output.clone(),
                    pearson: st::pearson(&x, &y),
                    spearman: st::spearman(&x, &y),
                });
            }
        }
        let mut failures: Vec<(String, u64)> = Vec::new();
        for r in table.rows.iter().filter(|r| r.failed()) {
            let reason = r
                .error
                .as_deref()
                .unwrap_or("")
                .lines()
                .next()
                .unwrap_or("")
                .to_string();
            match failures.iter_mut().find(|(m, _)| *m == reason) {
                Some(f) => f.1 += 1,
                None => failures.push((reason, 1)),
            }
        }
        failures.sort_by_key(|f| std::cmp::Reverse(f.1));
        Summary {
            study: study.to_string(),
            samples: table.rows.len() as u64,
            failed,
            outputs,
            correlations,
            failures,
        }
    }

    /// JSON: NaN (undefined statistics, e.g. σ of one sample) is written as null.
    pub fn to_json(&self) -> String {
        let mut s = serde_json::to_string_pretty(self).expect("serialisable");
        s.push('\n');
        s
    }

    /// The table printed after a run or a merge.
    pub fn table(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "study {}: {} samples, {} failed",
            self.study, self.samples, self.failed
        );
        let label = |o: &OutputSummary| {
            if o.unit.is_empty() || o.unit == "1" {
                o.name.clone()
            } else {
                format!("{} [{}]", o.name, o.unit)
            }
        };
        let w = self
            .outputs
            .iter()
            .map(|o| label(o).chars().count())
            .max()
            .unwrap_or(6)
            .max(6);
        let _ = writeln!(
            s,
            "{:<w$} {:>6} {:>13} {:>27} {:>11} {:>11} {:>11} {:>11} {:>11} {:>11}",
            "output", "n", "mean", "95% CI of mean", "sd", "min", "p1", "p50", "p99", "max"
        );
        let g = |v: f64| format!("{v:.5e}");
        for o in &self.outputs {
            let q = |p: f64| {
                o.quantiles
                    .iter()
                    .find(|(x, _)| *x == p)
                    .map_or(f64::NAN, |q| q.1)
            };
            let _ = writeln!(
                s,
                "{:<w$} {:>6} {:>13} {:>27} {:>11} {:>11} {:>11} {:>11} {:>11} {:>11}",
                label(o),
                o.count,
                g(o.mean),
                format!("[{}, {}]", g(o.mean_ci95.0), g(o.mean_ci95.1)),
                format!("{:.3e}", o.sd),
                format!("{:.3e}", o.min),
                format!("{:.3e}", q(0.01)),
                format!("{:.3e}", q(0.5)),
                format!("{:.3e}", q(0.99)),
                format!("{:.3e}", o.max),
            );
            if let Some(os) = &o.out_of_spec {
                let _ = writeln!(
                    s,
                    "{:<w$} out of spec [{}, {}]: {} = {:.3} % (95 % CI {:.3}–{:.3} %), Cp {}, Cpk {}",
                    "",
                    o.lower_limit.map_or("−∞".into(), |v| format!("{v:e}")),
                    o.upper_limit.map_or("∞".into(), |v| format!("{v:e}")),
                    os.count,
                    100.0 * os.fraction,
                    100.0 * os.wilson95.0,
                    100.0 * os.wilson95.1,
                    o.cp.map_or("–".into(), |v| format!("{v:.3}")),
                    o.cpk.map_or("–".into(), |v| format!("{v:.3}")),
                );
            }
        }
        if !self.correlations.is_empty() {
            let _ = writeln!(s, "correlations (Pearson / Spearman):");
            for c in &self.correlations {
                let _ = writeln!(
                    s,
                    "  {:<28} → {:<24} {:>7.3} / {:>7.3}",
                    c.input, c.output, c.pearson, c.spearman
                );
            }
        }
        for (reason, n) in &self.failures {
            let _ = writeln!(s, "failed ×{n}: {reason}");
        }
        s
    }
}
