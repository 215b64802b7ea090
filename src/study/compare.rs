//! Two runs of the same study compared sample by sample: each output's difference on
//! every sample in units of its Monte-Carlo σ (the reference's), with the percentiles,
//! the samples above a target and the largest, and each run's cost. `converge` judges a
//! fidelity on a few samples; this check covers every sample of a study run twice, at
//! the fidelity in use and at a finer one, and finds the samples whose course changes
//! with the step (a latch that slips at one step and holds at another).

use super::statistics::{quantile_sorted, sd};
use super::store::{Row, Table};
use std::collections::BTreeMap;
use std::fmt;

/// One output's differences over the samples both runs have values for.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputDifference {
    pub name: String,
    pub unit: String,
    /// The scale of the differences: the reference's σ over the compared samples, or,
    /// where that is zero (an output that does not vary), its largest |value|, the
    /// differences then relative (`relative`).
    pub scale: f64,
    pub relative: bool,
    /// Samples with a value in both runs.
    pub compared: usize,
    pub median: f64,
    pub p90: f64,
    /// The largest difference and its sample.
    pub largest: Option<(f64, u64)>,
    /// Samples whose difference exceeds the target, and five times the target.
    pub above_target: usize,
    pub above_5_target: usize,
}

/// The comparison of `other` with `reference`.
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    pub target: f64,
    pub outputs: Vec<OutputDifference>,
    /// Outputs of one run only, by name.
    pub unmatched_outputs: Vec<String>,
    /// Samples in both runs; in the reference only; in the other only.
    pub common: usize,
    pub reference_only: usize,
    pub other_only: usize,
    /// Common samples that failed in either run (left out of the differences).
    pub failed: usize,
    /// Samples above the target on some output, in increasing order of sample id.
    pub samples_above_target: Vec<u64>,
    /// Median steps and wall time (ms) a sample, of the reference and of the other run.
    pub cost: [(f64, f64); 2],
    /// Per common sample (not failed), its id and each output's difference in units of
    /// its scale (NaN where one run has no value).
    pub per_sample: Vec<(u64, Vec<f64>)>,
}

/// Compares `other` with `reference` sample by sample (matched by sample id); `target` is
/// the difference, in units of σ, that counts a sample as off.
pub fn compare(reference: &Table, other: &Table, target: f64) -> Comparison {
    let by_id = |t: &Table| -> BTreeMap<u64, usize> {
        t.rows.iter().enumerate().map(|(k, r)| (r.id, k)).collect()
    };
    let (ref_ids, other_ids) = (by_id(reference), by_id(other));
    let common: Vec<(u64, &Row, &Row)> = ref_ids
        .iter()
        .filter_map(|(id, &k)| {
            let j = *other_ids.get(id)?;
            Some((*id, &reference.rows[k], &other.rows[j]))
        })
        .collect();
    let pairs: Vec<&(u64, &Row, &Row)> = common
        .iter()
        .filter(|(_, a, b)| !a.failed() && !b.failed())
        .collect();
    let other_index = |name: &str| other.columns.outputs.iter().position(|(n, _)| n == name);
    let mut unmatched_outputs: Vec<String> = reference
        .columns
        .outputs
        .iter()
        .filter(|(n, _)| other_index(n).is_none())
        .map(|(n, _)| n.clone())
        .collect();
    unmatched_outputs.extend(
        other
            .columns
            .outputs
            .iter()
            .filter(|(n, _)| !reference.columns.outputs.iter().any(|(m, _)| m == n))
            .map(|(n, _)| n.clone()),
    );
    let matched: Vec<(usize, usize)> = (reference.columns.outputs.iter().enumerate())
        .filter_map(|(i, (n, _))| Some((i, other_index(n)?)))
        .collect();
    let mut per_sample: Vec<(u64, Vec<f64>)> =
        pairs.iter().map(|(id, _, _)| (*id, Vec::new())).collect();
    let mut outputs = Vec::new();
    for &(i, j) in &matched {
        let (name, unit) = reference.columns.outputs[i].clone();
        let values: Vec<f64> = pairs
            .iter()
            .map(|(_, a, _)| a.outputs[i])
            .filter(|x| x.is_finite())
            .collect();
        let sigma = sd(&values);
        let relative = !(sigma.is_finite() && sigma > 0.0);
        let scale = match relative {
            false => sigma,
            true => values.iter().fold(0.0, |m: f64, x| m.max(x.abs())),
        };
        let mut differences = Vec::new();
        let mut largest: Option<(f64, u64)> = None;
        for (k, (id, a, b)) in pairs.iter().enumerate() {
            let d = (b.outputs[j] - a.outputs[i]).abs() / scale;
            per_sample[k].1.push(d);
            if d.is_finite() {
                differences.push(d);
                if largest.is_none_or(|(m, _)| d > m) {
                    largest = Some((d, *id));
                }
            }
        }
        differences.sort_by(f64::total_cmp);
        outputs.push(OutputDifference {
            name,
            unit,
            scale,
            relative,
            compared: differences.len(),
            median: quantile_sorted(&differences, 0.5),
            p90: quantile_sorted(&differences, 0.9),
            largest,
            above_target: differences.iter().filter(|&&d| d > target).count(),
            above_5_target: differences.iter().filter(|&&d| d > 5.0 * target).count(),
        });
    }
    let samples_above_target = per_sample
        .iter()
        .filter(|(_, d)| d.iter().any(|&x| x > target))
        .map(|(id, _)| *id)
        .collect();
    let cost = |of_other: bool| {
        let diagnostics = pairs.iter().map(|(_, a, b)| match of_other {
            true => b.diagnostics,
            false => a.diagnostics,
        });
        let mut steps: Vec<f64> = diagnostics.clone().map(|d| d.steps as f64).collect();
        let mut wall: Vec<f64> = diagnostics.map(|d| d.wall_ms).collect();
        steps.sort_by(f64::total_cmp);
        wall.sort_by(f64::total_cmp);
        (quantile_sorted(&steps, 0.5), quantile_sorted(&wall, 0.5))
    };
    Comparison {
        target,
        outputs,
        unmatched_outputs,
        common: common.len(),
        reference_only: ref_ids.len() - common.len(),
        other_only: other_ids.len() - common.len(),
        failed: common.len() - pairs.len(),
        samples_above_target,
        cost: [cost(false), cost(true)],
        per_sample,
    }
}

impl Comparison {
    /// Whether every compared output is within the target on every compared sample.
    pub fn within_target(&self) -> bool {
        self.samples_above_target.is_empty()
    }

    /// The per-sample differences as CSV: `sample_id`, then one column per output.
    pub fn csv(&self) -> String {
        let mut s = String::from("sample_id");
        for o in &self.outputs {
            s += &format!(",{}", o.name);
        }
        s.push('\n');
        for (id, d) in &self.per_sample {
            s += &id.to_string();
            for x in d {
                s += &format!(",{x:e}");
            }
            s.push('\n');
        }
        s
    }
}

impl fmt::Display for Comparison {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        let percent = |x: f64| format!("{:.3} %", 100.0 * x);
        writeln!(
            f,
            "samples: {} in both ({} failed in either, left out), {} in the reference only, {} in the other only",
            self.common, self.failed, self.reference_only, self.other_only
        )?;
        let [(s0, w0), (s1, w1)] = self.cost;
        writeln!(
            f,
            "median cost a sample: reference {s0:.0} steps, {w0:.1} ms; other {s1:.0} steps, {w1:.1} ms"
        )?;
        writeln!(
            f,
            "differences in units of the reference's σ (relative where σ = 0), sample by sample:"
        )?;
        let width = self
            .outputs
            .iter()
            .map(|o| o.name.len())
            .max()
            .unwrap_or(6)
            .max(6);
        let t = percent(self.target);
        let above = |x: f64| format!("> {} %", (1e5 * x).round() / 1e3);
        writeln!(
            f,
            "{:width$}  {:>9}  {:>9}  {:>8}  {:>8}  {:>9}  {:>9}",
            "output",
            "median",
            "p90",
            above(self.target),
            above(5.0 * self.target),
            "largest",
            "at sample",
        )?;
        for o in &self.outputs {
            let (largest, at) = match o.largest {
                Some((d, id)) => (percent(d), id.to_string()),
                None => ("-".into(), "-".into()),
            };
            let name = match o.relative {
                true => format!("{} (rel.)", o.name),
                false => o.name.clone(),
            };
            writeln!(
                f,
                "{name:width$}  {:>9}  {:>9}  {:>8}  {:>8}  {largest:>9}  {at:>9}",
                percent(o.median),
                percent(o.p90),
                o.above_target,
                o.above_5_target,
            )?;
        }
        if !self.unmatched_outputs.is_empty() {
            writeln!(
                f,
                "not compared (in one run only): {}",
                self.unmatched_outputs.join(", ")
            )?;
        }
        let compared = self.per_sample.len();
        match self.samples_above_target.as_slice() {
            [] => writeln!(
                f,
                "every output within {t} of σ on all {compared} compared samples"
            ),
            above => {
                let shown: Vec<String> = above.iter().take(12).map(u64::to_string).collect();
                let more = match above.len() > 12 {
                    true => ", …",
                    false => "",
                };
                writeln!(
                    f,
                    "{} of {compared} samples above {t} of σ on some output: {}{more}",
                    above.len(),
                    shown.join(", ")
                )
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::sample_run::Diagnostics;
    use crate::study::store::Columns;

    fn table(outputs: &[&str], rows: Vec<(u64, Vec<f64>, bool)>) -> Table {
        Table {
            columns: Columns {
                inputs: Vec::new(),
                outputs: outputs
                    .iter()
                    .map(|n| (n.to_string(), "s".into()))
                    .collect(),
                tagged: false,
                optional: false,
                curves: Vec::new(),
            },
            rows: rows
                .into_iter()
                .map(|(id, outputs, failed)| Row {
                    id,
                    inputs: Vec::new(),
                    outputs,
                    diagnostics: Diagnostics {
                        steps: 100 * id,
                        wall_ms: id as f64,
                        ..Default::default()
                    },
                    error: failed.then(|| "failed".into()),
                    suspect: None,
                    missing: None,
                    curves: Vec::new(),
                    tag: None,
                })
                .collect(),
            metadata: Default::default(),
            digest: String::new(),
        }
    }

    /// Reference values 0, 1, …, 10 (σ = √11 = 3.317): the other run differs by k/100 of
    /// σ on sample k, so the median is 5 %, the 90th percentile 9 %, the largest 10 % on
    /// sample 10, and samples 2…10 exceed a 1 % target (9 of them), 6…10 a 5 % one.
    #[test]
    fn differences_are_in_units_of_the_references_sigma() {
        let sigma = 11f64.sqrt();
        let reference = table(
            &["x"],
            (0..=10).map(|k| (k, vec![k as f64], false)).collect(),
        );
        let other = table(
            &["x"],
            (0..=10)
                .rev()
                .map(|k| (k, vec![k as f64 - 0.01 * k as f64 * sigma], false))
                .collect(),
        );
        let c = compare(&reference, &other, 0.011);
        let o = &c.outputs[0];
        assert!((o.scale - sigma).abs() < 1e-12, "{}", o.scale);
        assert!((o.median - 0.05).abs() < 1e-12, "{}", o.median);
        assert!((o.p90 - 0.09).abs() < 1e-12, "{}", o.p90);
        let (d, at) = o.largest.unwrap();
        assert!((d - 0.10).abs() < 1e-12 && at == 10, "{d} {at}");
        assert_eq!((o.above_target, o.above_5_target), (9, 5));
        assert_eq!(c.samples_above_target, (2..=10).collect::<Vec<_>>());
        assert!(!c.within_target());
        assert_eq!(c.cost, [(500.0, 5.0), (500.0, 5.0)]);
        let shown = c.to_string();
        assert!(
            shown.contains("9 of 11 samples above 1.100 % of σ"),
            "{shown}"
        );
        assert!(
            shown.contains("10.000 %") && shown.contains("10\n"),
            "{shown}"
        );
    }

    /// Samples are matched by id; one failed in either run, or present in one run only,
    /// is left out and counted; an output of one run only is named; an output that does
    /// not vary is compared relative to its size.
    #[test]
    fn unmatched_and_failed_samples_are_counted_and_left_out() {
        let reference = table(
            &["x", "c", "only_ref"],
            vec![
                (1, vec![1.0, 2.0, 0.0], false),
                (2, vec![2.0, 2.0, 0.0], false),
                (3, vec![3.0, 2.0, 0.0], false),
                (4, vec![f64::NAN, f64::NAN, f64::NAN], true),
                (5, vec![5.0, 2.0, 0.0], false),
            ],
        );
        let other = table(
            &["c", "x"],
            vec![
                (2, vec![2.0, 2.0], false),
                (3, vec![2.002, 3.0], false),
                (4, vec![2.0, 4.0], false),
                (5, vec![2.0, 5.0], false),
                (6, vec![2.0, 6.0], false),
            ],
        );
        let c = compare(&reference, &other, 0.01);
        assert_eq!(
            (c.common, c.failed, c.reference_only, c.other_only),
            (4, 1, 1, 1)
        );
        assert_eq!(c.per_sample.len(), 3);
        assert_eq!(c.unmatched_outputs, vec!["only_ref".to_string()]);
        let x = &c.outputs[0];
        assert_eq!(
            (x.name.as_str(), x.relative, x.largest.unwrap().0),
            ("x", false, 0.0)
        );
        let constant = &c.outputs[1];
        assert!(constant.relative);
        assert_eq!(constant.scale, 2.0);
        let (d, at) = constant.largest.unwrap();
        assert!((d - 1e-3).abs() < 1e-12 && at == 3, "{d} {at}");
        assert!(c.within_target(), "{c}");
        assert!(c
            .to_string()
            .contains("every output within 1.000 % of σ on all 3"));
        let csv = c.csv();
        assert_eq!(csv.lines().next(), Some("sample_id,x,c"));
        assert_eq!(csv.lines().count(), 4);
    }
}
