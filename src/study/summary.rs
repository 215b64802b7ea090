//! `OUT/summary.json` and the printed table: per output, count, failures, mean with its
//! 95 % interval, σ, range, quantiles, histogram, out-of-spec fraction (Wilson 95 %) and
//! Cp/Cpk; per input–output pair, Pearson and Spearman correlation. The JSON holds SI
//! values; the table shows each output in its display unit, with as many digits as its
//! spread needs.

use super::statistics as st;
use super::store::Table;
use super::{Output, Parameter};
use crate::input::units::{Dim, DisplayUnit};
use anyhow::{Context, Result};
use serde::{Deserialize, Deserializer, Serialize};
use std::fmt::{self, Write};
use std::path::Path;

pub const QUANTILES: [f64; 5] = [0.01, 0.05, 0.5, 0.95, 0.99];

/// The table lists, per output, the inputs whose |Spearman ρ| is at least this…
const STRONG_CORRELATION: f64 = 0.1;
/// …the strongest first, at most this many.
const STRONGEST_INPUTS: usize = 3;

/// JSON writes an undefined statistic (NaN: σ of one sample) as null; read it back as NaN.
fn nan<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

fn nan_pair<'de, D: Deserializer<'de>>(d: D) -> Result<(f64, f64), D::Error> {
    let (a, b) = <(Option<f64>, Option<f64>)>::deserialize(d)?;
    Ok((a.unwrap_or(f64::NAN), b.unwrap_or(f64::NAN)))
}

fn nan_pairs<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<(f64, f64)>, D::Error> {
    let v = Vec::<(Option<f64>, Option<f64>)>::deserialize(d)?;
    Ok(v.into_iter()
        .map(|(a, b)| (a.unwrap_or(f64::NAN), b.unwrap_or(f64::NAN)))
        .collect())
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct OutputSummary {
    pub name: String,
    /// SI unit of every value below.
    pub unit: String,
    /// The unit the table and the report show it in.
    pub display_unit: String,
    /// Display value = SI value × this.
    pub display_factor: f64,
    /// Why the value depends on the step size, if it does.
    pub caution: Option<String>,
    /// Successful samples with a value.
    pub count: u64,
    pub failed: u64,
    /// Samples that went through without a value for this (optional) output.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub missing: u64,
    /// The values are one value up to round-off (range ≤ 1e-9 of their magnitude): the
    /// output is shown as that value, without a spread.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub constant: bool,
    #[serde(deserialize_with = "nan")]
    pub mean: f64,
    #[serde(deserialize_with = "nan_pair")]
    pub mean_ci95: (f64, f64),
    #[serde(deserialize_with = "nan")]
    pub sd: f64,
    #[serde(deserialize_with = "nan")]
    pub min: f64,
    #[serde(deserialize_with = "nan")]
    pub max: f64,
    /// (p, value) for p in 1, 5, 50, 95, 99 %.
    #[serde(deserialize_with = "nan_pairs")]
    pub quantiles: Vec<(f64, f64)>,
    pub histogram: Histogram,
    pub lower_limit: Option<f64>,
    pub upper_limit: Option<f64>,
    pub out_of_spec: Option<OutOfSpec>,
    pub cp: Option<f64>,
    pub cpk: Option<f64>,
}

impl OutputSummary {
    /// The display unit of the table and the report.
    pub fn display(&self) -> DisplayUnit {
        DisplayUnit {
            label: self.display_unit.clone(),
            per_si: self.display_factor,
        }
    }

    /// The p-quantile (p among [`QUANTILES`]), NaN if absent.
    pub fn quantile(&self, p: f64) -> f64 {
        self.quantiles
            .iter()
            .find(|(x, _)| *x == p)
            .map_or(f64::NAN, |q| q.1)
    }

    /// Decimals that show the spread: σ with two significant digits (six significant
    /// digits of the mean when σ is zero or undefined), in the display unit.
    pub fn decimals(&self) -> usize {
        let d = self.display();
        let (sd, mean) = (d.of(self.sd).abs(), d.of(self.mean).abs());
        let digits = if sd.is_finite() && sd > 0.0 && !self.constant {
            1.0 - sd.log10().floor()
        } else if mean.is_finite() && mean > 0.0 {
            5.0 - mean.log10().floor()
        } else {
            3.0
        };
        digits.clamp(0.0, 12.0) as usize
    }

    /// An SI value in the display unit with the output's decimals ("–" if undefined); a
    /// constant's value with six significant digits.
    pub fn show(&self, si: f64) -> String {
        let v = self.display().of(si);
        if self.constant && v != 0.0 && v.abs() < 1e-4 {
            return format!("{v:.5e}");
        }
        fixed(v, self.decimals())
    }
}

/// A fraction as a percentage with 3 decimals ("–" if undefined, as with no samples).
pub fn percent(fraction: f64) -> String {
    if fraction.is_finite() {
        format!("{:.3}", 100.0 * fraction)
    } else {
        "–".into()
    }
}

/// `v` with `decimals` decimals, in exponent form beyond 1e7 ("–" if not finite).
fn fixed(v: f64, decimals: usize) -> String {
    if !v.is_finite() {
        "–".into()
    } else if v.abs() >= 1e7 {
        format!("{v:.3e}")
    } else {
        format!("{v:.decimals$}")
    }
}

/// An input as the study states it (a drawing's tolerance, or a distribution), with the
/// mean and σ that statement means.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct InputSummary {
    pub name: String,
    pub stated: String,
    /// SI unit.
    pub unit: String,
    #[serde(deserialize_with = "nan")]
    pub mean: f64,
    #[serde(deserialize_with = "nan")]
    pub sd: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Histogram {
    #[serde(deserialize_with = "nan")]
    pub lower: f64,
    #[serde(deserialize_with = "nan")]
    pub width: f64,
    pub counts: Vec<u64>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct OutOfSpec {
    pub count: u64,
    #[serde(deserialize_with = "nan")]
    pub fraction: f64,
    #[serde(deserialize_with = "nan_pair")]
    pub wilson95: (f64, f64),
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Correlation {
    pub input: String,
    pub output: String,
    #[serde(deserialize_with = "nan")]
    pub pearson: f64,
    #[serde(deserialize_with = "nan")]
    pub spearman: f64,
    /// The input's standardised rank regression coefficient for this output: its rank
    /// correlation with the others' held fixed, so that an input which merely happens to
    /// be correlated with a strong one in the sample does not borrow its sign. NaN where
    /// the regression cannot be formed (fewer rows than inputs + 2, a constant output).
    #[serde(default = "no_value", deserialize_with = "nan")]
    pub srrc: f64,
}

fn no_value() -> f64 {
    f64::NAN
}

fn is_zero(n: &u64) -> bool {
    *n == 0
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Summary {
    pub study: String,
    pub samples: u64,
    pub failed: u64,
    /// The inputs as the study states them.
    #[serde(default)]
    pub inputs: Vec<InputSummary>,
    pub outputs: Vec<OutputSummary>,
    pub correlations: Vec<Correlation>,
    /// Failure reasons (first line) with their counts, most frequent first.
    pub failures: Vec<(String, u64)>,
    /// Samples whose run went through with a fault (their values are in the statistics).
    #[serde(default)]
    pub suspect: u64,
    /// Their reasons with counts, most frequent first.
    #[serde(default)]
    pub suspicions: Vec<(String, u64)>,
    /// The curves' pointwise median and 5–95 % band.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub curves: Vec<super::curves::CurveSummary>,
}

/// `text` without its ` (…)` parts: the kind of a reason, without its figures.
fn without_details(text: &str) -> String {
    let mut out = String::new();
    let mut depth = 0usize;
    for c in text.chars() {
        match c {
            '(' => depth += 1,
            ')' if depth > 0 => depth -= 1,
            _ if depth == 0 => out.push(c),
            _ => {}
        }
    }
    out.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Reasons (first lines, without their parenthesised details) with their counts, most
/// frequent first.
fn tally<'a>(reasons: impl Iterator<Item = &'a str>, details: bool) -> Vec<(String, u64)> {
    let mut out: Vec<(String, u64)> = Vec::new();
    for r in reasons {
        let mut reason = r.lines().next().unwrap_or("").to_string();
        if !details {
            reason = without_details(&reason);
        }
        match out.iter_mut().find(|(m, _)| *m == reason) {
            Some(f) => f.1 += 1,
            None => out.push((reason, 1)),
        }
    }
    out.sort_by_key(|f| std::cmp::Reverse(f.1));
    out
}

/// The display unit of each output: the one its probe declares, else one chosen for all the
/// outputs of its dimension together (from the largest magnitude among them), so that
/// similar outputs (FC-2…FC-6, all lengths) share a unit.
fn display_units(outputs: &[Output], values: &[Vec<f64>]) -> Vec<DisplayUnit> {
    let dims: Vec<Option<Dim>> = outputs.iter().map(|o| Dim::of_unit(&o.unit)).collect();
    let big = |dim: Dim| {
        (0..outputs.len())
            .filter(|&k| dims[k] == Some(dim) && outputs[k].display.is_none())
            .flat_map(|k| values[k].iter())
            .filter(|v| v.is_finite())
            .fold(0.0f64, |m, v| m.max(v.abs()))
    };
    outputs
        .iter()
        .zip(&dims)
        .map(|(o, dim)| match (&o.display, dim) {
            (Some(d), _) => d.clone(),
            (None, Some(dim)) => DisplayUnit::auto(*dim, big(*dim)),
            (None, None) => DisplayUnit::for_values(&o.unit, &[]),
        })
        .collect()
}

impl Summary {
    /// The summary of `table`, whose output columns are `outputs` in order.
    pub fn of(study: &str, table: &Table, outputs: &[Output]) -> Summary {
        let ok: Vec<_> = table.rows.iter().filter(|r| !r.failed()).collect();
        let failed = table.rows.len() as u64 - ok.len() as u64;
        // an optional output may be NaN in a run that went through: its statistics take the
        // runs that have it
        let values: Vec<Vec<f64>> = (0..outputs.len())
            .map(|k| {
                let mut x: Vec<f64> = ok
                    .iter()
                    .map(|r| r.outputs[k])
                    .filter(|v| !v.is_nan())
                    .collect();
                x.sort_by(f64::total_cmp);
                x
            })
            .collect();
        let units = display_units(outputs, &values);
        let mut summaries = Vec::new();
        for ((o, x), display) in outputs.iter().zip(&values).zip(units) {
            let (lower, upper) = (o.lower, o.upper);
            let (mean, sd) = (st::mean(x), st::sd(x));
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
            // a constant output has no spread to compare with its limits
            let (cp, cpk) = if st::is_constant(x) {
                (None, None)
            } else {
                st::capability(mean, sd, lower, upper)
            };
            let (hl, hw, counts) = st::histogram(x);
            summaries.push(OutputSummary {
                name: o.name.clone(),
                unit: o.unit.clone(),
                display_unit: display.label,
                display_factor: display.per_si,
                caution: o.caution.clone(),
                count: x.len() as u64,
                failed,
                missing: ok.len() as u64 - x.len() as u64,
                constant: x.len() > 1 && st::is_constant(x),
                mean,
                mean_ci95: st::mean_ci95(x),
                sd,
                min: x.first().copied().unwrap_or(f64::NAN),
                max: x.last().copied().unwrap_or(f64::NAN),
                quantiles: QUANTILES
                    .iter()
                    .map(|&p| (p, st::quantile_sorted(x, p)))
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
        let columns: Vec<Vec<f64>> = (0..table.columns.inputs.len())
            .map(|i| ok.iter().map(|r| r.inputs[i]).collect())
            .collect();
        let srrc: Vec<Vec<f64>> = (0..table.columns.outputs.len())
            .map(|k| {
                let y: Vec<f64> = ok.iter().map(|r| r.outputs[k]).collect();
                if st::is_constant(&y) {
                    return vec![f64::NAN; columns.len()];
                }
                super::sensitivity::srrc(&columns, &y)
                    .map_or(vec![f64::NAN; columns.len()], |r| r.coefficients)
            })
            .collect();
        let mut correlations = Vec::new();
        for (i, (input, _)) in table.columns.inputs.iter().enumerate() {
            let x = &columns[i];
            for (k, (output, _)) in table.columns.outputs.iter().enumerate() {
                let (x, y): (Vec<f64>, Vec<f64>) = x
                    .iter()
                    .zip(ok.iter().map(|r| r.outputs[k]))
                    .filter(|(_, y)| !y.is_nan())
                    .unzip();
                correlations.push(Correlation {
                    input: input.clone(),
                    output: output.clone(),
                    pearson: st::pearson(&x, &y),
                    spearman: st::spearman(&x, &y),
                    srrc: srrc[k][i],
                });
            }
        }
        let failures = tally(table.rows.iter().filter_map(|r| r.error.as_deref()), true);
        let suspicions = tally(
            table.rows.iter().filter_map(|r| r.suspect.as_deref()),
            false,
        );
        Summary {
            study: study.to_string(),
            samples: table.rows.len() as u64,
            failed,
            inputs: Vec::new(),
            outputs: summaries,
            correlations,
            failures,
            suspect: suspicions.iter().map(|(_, n)| n).sum(),
            suspicions,
            curves: Vec::new(),
        }
    }

    /// The summary with the study's inputs as it states them.
    pub fn with_inputs(mut self, parameters: &[Parameter]) -> Summary {
        self.inputs = parameters
            .iter()
            .map(|p| {
                let (mean, sd) = p.distribution.moments();
                InputSummary {
                    name: p.path.clone(),
                    stated: p.stated(),
                    unit: p.unit.clone(),
                    mean,
                    sd,
                }
            })
            .collect();
        self
    }

    /// The summary with the curves of `table`, shown in the units `curves` (the scene's)
    /// ask for.
    pub fn with_curves(mut self, table: &Table, curves: &[crate::probe::curve::Curve]) -> Summary {
        self.curves = super::curves::CurveSummary::all(table, curves);
        self
    }

    /// JSON: NaN (undefined statistics, e.g. σ of one sample) is written as null.
    pub fn to_json(&self) -> String {
        let mut s = serde_json::to_string_pretty(self).expect("serialisable");
        s.push('\n');
        s
    }

    /// `dir/summary.json`, if the directory has one.
    pub fn load(dir: &Path) -> Result<Option<Summary>> {
        let path = dir.join("summary.json");
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(e).with_context(|| format!("reading {}", path.display())),
        };
        serde_json::from_str(&text)
            .map(Some)
            .with_context(|| format!("{} is not a summary of mc-study", path.display()))
    }

    /// The summary of the output `name`, if it has one.
    pub fn output(&self, name: &str) -> Option<&OutputSummary> {
        self.outputs.iter().find(|o| o.name == name)
    }

    /// The inputs that drive `output` most (|SRRC| ≥ 0.1, the strongest first, at most
    /// three), each with its measure: the standardised rank regression coefficient, or
    /// Spearman's ρ where the regression cannot be formed.
    pub fn strongest_inputs(&self, output: &str) -> Vec<(&Correlation, f64)> {
        let mut v: Vec<(&Correlation, f64)> = self
            .correlations
            .iter()
            .filter(|c| c.output == output)
            .map(|c| (c, if c.srrc.is_nan() { c.spearman } else { c.srrc }))
            .filter(|(_, m)| m.abs() >= STRONG_CORRELATION)
            .collect();
        v.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
        v.truncate(STRONGEST_INPUTS);
        v
    }
}

/// Columns of a printed table, the first `left` left-aligned and the others right-aligned.
pub fn write_columns(s: &mut String, rows: &[Vec<String>], left: usize) {
    let n = rows.iter().map(Vec::len).max().unwrap_or(0);
    let widths: Vec<usize> = (0..n)
        .map(|c| {
            rows.iter()
                .filter_map(|r| r.get(c))
                .map(|x| x.chars().count())
                .max()
                .unwrap_or(0)
        })
        .collect();
    for r in rows {
        let mut line = String::new();
        for (c, x) in r.iter().enumerate() {
            let pad = widths[c] - x.chars().count();
            if c < left {
                line.push_str(x);
                line.push_str(&" ".repeat(pad));
            } else {
                line.push_str(&" ".repeat(pad));
                line.push_str(x);
            }
            line.push_str("  ");
        }
        let _ = writeln!(s, "{}", line.trim_end());
    }
}

/// The table printed after a run or a merge: each output in its display unit, the
/// mean's 95 % interval as ±, the strongest inputs per output, the cautions, and the
/// failures by reason.
impl fmt::Display for Summary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut s = String::new();
        let suspect = if self.suspect > 0 {
            format!(", {} suspect (in the statistics; see below)", self.suspect)
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "study {}: {} samples, {} failed{suspect}",
            self.study, self.samples, self.failed
        );
        if !self.inputs.is_empty() {
            let w = self
                .inputs
                .iter()
                .map(|i| i.name.chars().count())
                .max()
                .unwrap_or(0);
            let _ = writeln!(s, "inputs:");
            for i in &self.inputs {
                let _ = writeln!(s, "  {:w$}  {}", i.name, i.stated);
            }
        }
        let mut rows = vec![[
            "output", "unit", "n", "mean", "±95%", "σ", "min", "p1", "p50", "p99", "max",
        ]
        .map(String::from)
        .to_vec()];
        for o in &self.outputs {
            let flag = if o.caution.is_some() { " (!)" } else { "" };
            if o.constant {
                rows.push(vec![
                    format!("{}{flag}", o.name),
                    o.display_unit.clone(),
                    o.count.to_string(),
                    o.show(o.mean),
                    "constant".into(),
                ]);
                continue;
            }
            rows.push(vec![
                format!("{}{flag}", o.name),
                o.display_unit.clone(),
                o.count.to_string(),
                o.show(o.mean),
                o.show(0.5 * (o.mean_ci95.1 - o.mean_ci95.0)),
                o.show(o.sd),
                o.show(o.min),
                o.show(o.quantile(0.01)),
                o.show(o.quantile(0.5)),
                o.show(o.quantile(0.99)),
                o.show(o.max),
            ]);
        }
        write_columns(&mut s, &rows, 2);
        for o in self.outputs.iter().filter(|o| o.missing > 0) {
            let _ = writeln!(
                s,
                "{}: {} of {} samples that went through have no value (an optional output: the `missing` column says why)",
                o.name,
                o.missing,
                o.count + o.missing
            );
        }
        for o in &self.outputs {
            if let Some(os) = &o.out_of_spec {
                let limit = |v: Option<f64>, none: &str| v.map_or(none.into(), |v| o.show(v));
                let _ = writeln!(
                    s,
                    "{}: out of spec [{}, {}] {}: {} = {} % (95 % CI {}–{} %), Cp {}, Cpk {}{}",
                    o.name,
                    limit(o.lower_limit, "−∞"),
                    limit(o.upper_limit, "∞"),
                    o.display_unit,
                    os.count,
                    percent(os.fraction),
                    percent(os.wilson95.0),
                    percent(os.wilson95.1),
                    o.cp.map_or("–".into(), |v| format!("{v:.3}")),
                    o.cpk.map_or("–".into(), |v| format!("{v:.3}")),
                    if o.cpk.is_none() && o.count > 1 {
                        " (the output is constant: no spread to rate)"
                    } else if o.cpk.is_none() {
                        " (fewer than 2 samples: no spread to rate)"
                    } else {
                        ""
                    },
                );
            }
        }
        if !self.correlations.is_empty() {
            let _ = writeln!(
                s,
                "strongest inputs (standardised rank regression coefficient SRRC, |SRRC| ≥ {STRONG_CORRELATION}, at most {STRONGEST_INPUTS} per output; all pairs in summary.json):"
            );
            let w = self.outputs.iter().map(|o| o.name.len()).max().unwrap_or(0);
            for o in &self.outputs {
                let strongest = self.strongest_inputs(&o.name);
                let list = if strongest.is_empty() {
                    format!("none with |SRRC| ≥ {STRONG_CORRELATION}")
                } else {
                    strongest
                        .iter()
                        .map(|(c, m)| format!("{} {m:+.2}", c.input))
                        .collect::<Vec<_>>()
                        .join(", ")
                };
                let _ = writeln!(s, "  {:w$}  {list}", o.name);
            }
        }
        for c in &self.curves {
            let median: Vec<f64> = c.median.iter().flatten().copied().collect();
            let (lo, hi) = median
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                    (a.min(*v), b.max(*v))
                });
            let show = |v: f64| format!("{:.4}", v * c.display_factor);
            let _ = write!(
                s,
                "curve {}: {} samples on {} grid points of {}",
                c.name, c.samples, c.grid.count, c.x
            );
            let _ = match median.len() {
                0 => writeln!(s, ", none with a value"),
                n => writeln!(
                    s,
                    "; median from {} to {} {} over the {n} points with a value (band and measured points: `mc-study report`)",
                    show(lo),
                    show(hi),
                    c.display_unit
                ),
            };
        }
        for o in &self.outputs {
            if let Some(c) = &o.caution {
                let _ = writeln!(s, "(!) {}: {c}", o.name);
            }
        }
        for (reason, n) in &self.failures {
            let _ = writeln!(s, "failed ×{n}: {reason}");
        }
        for (reason, n) in &self.suspicions {
            let _ = writeln!(s, "suspect ×{n}: {reason}");
        }
        f.write_str(&s)
    }
}
