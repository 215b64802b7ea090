//! The table tolerance engineers expect, per output: the worst case over the tolerance
//! box, the linear stack-up's prediction (RSS, mean ± 3σ, with R²), and the Monte-Carlo
//! range, beside the limits, with which of them break the limits.

use super::stack_up::{stack_up, StackUp};
use super::worst_case_run::WorstCase;
use crate::study::store::Table;
use crate::study::summary::Summary;
use crate::study::Study;
use std::fmt::Write;

/// One output's row.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Comparison {
    pub output: String,
    pub unit: String,
    pub lower: Option<f64>,
    pub upper: Option<f64>,
    /// Searched extremes over the box.
    pub worst_case: Option<(f64, f64)>,
    /// The linear stack-up.
    pub stack_up: Option<StackUp>,
    /// Monte-Carlo min and max, and the 0.135 % and 99.865 % quantiles (± 3σ of a normal).
    pub monte_carlo: Option<[f64; 4]>,
}

impl Comparison {
    /// RSS limits: mean ± 3σ.
    pub fn rss(&self) -> Option<(f64, f64)> {
        self.stack_up
            .as_ref()
            .map(|s| (s.mean - 3.0 * s.sigma, s.mean + 3.0 * s.sigma))
    }

    /// Whether a range breaks the limits.
    pub fn breaks(&self, (lo, hi): (f64, f64)) -> bool {
        self.lower.is_some_and(|l| lo < l) || self.upper.is_some_and(|u| hi > u)
    }
}

/// The rows of every output of `study`, from its stored results (`results`, merged or
/// not) and its worst-case search, whichever exist.
pub fn compare(
    study: &Study,
    results: Option<(&Table, &Summary)>,
    worst: Option<&WorstCase>,
) -> Vec<Comparison> {
    // the regression uses independent rows only: for Saltelli, the A and B blocks
    let d = study.parameters.len();
    let sigmas = worst.map_or(crate::study::tolerance::BOX_SIGMAS, |w| w.sigmas);
    let saltelli = study.design.kind == crate::study::DesignKind::Saltelli;
    study
        .outputs
        .iter()
        .enumerate()
        .map(|(k, o)| {
            let (stack, mc) = match results {
                Some((table, summary)) => {
                    let rows: Vec<_> = table
                        .rows
                        .iter()
                        .filter(|r| !r.failed() && (!saltelli || r.id % (d as u64 + 2) < 2))
                        .collect();
                    let x: Vec<Vec<f64>> = (0..d)
                        .map(|j| rows.iter().map(|r| r.inputs[j]).collect())
                        .collect();
                    let y: Vec<f64> = rows.iter().map(|r| r.outputs[k]).collect();
                    let mc = summary.output(&o.name).map(|s| {
                        let mut v = y.clone();
                        v.retain(|x| x.is_finite());
                        v.sort_by(f64::total_cmp);
                        let q = |p| crate::study::statistics::quantile_sorted(&v, p);
                        [s.min, s.max, q(0.00135), q(0.99865)]
                    });
                    (stack_up(study, &o.name, &x, &y, sigmas), mc)
                }
                None => (None, None),
            };
            let worst_case = worst.and_then(|w| {
                let e = &w.extremes[w.outputs.iter().position(|n| *n == o.name)?];
                Some((e.min.as_ref()?.value, e.max.as_ref()?.value))
            });
            Comparison {
                output: o.name.clone(),
                unit: o.unit.clone(),
                lower: o.lower,
                upper: o.upper,
                worst_case,
                stack_up: stack,
                monte_carlo: mc,
            }
        })
        .collect()
}

/// The table as text, each output in the display unit of `summary` (or SI).
pub fn describe(rows: &[Comparison], summary: Option<&Summary>) -> String {
    let mut s = String::new();
    for c in rows {
        let show = |v: f64| match summary.and_then(|m| m.output(&c.output)) {
            Some(o) => format!("{} {}", o.show(v), o.display_unit),
            None => format!("{v:.6e} {}", c.unit),
        };
        let range = |(a, b): (f64, f64)| {
            format!(
                "[{}, {}]{}",
                show(a),
                show(b),
                if c.breaks((a, b)) {
                    "  BREAKS THE LIMITS"
                } else {
                    ""
                }
            )
        };
        let limits = match (c.lower, c.upper) {
            (None, None) => "no limits".to_string(),
            (l, u) => format!(
                "limits [{}, {}]",
                l.map_or("−∞".into(), show),
                u.map_or("∞".into(), show)
            ),
        };
        let _ = writeln!(s, "{}: {limits}", c.output);
        if let Some(w) = c.worst_case {
            let _ = writeln!(s, "  worst case (searched)   {}", range(w));
        }
        if let Some(st) = &c.stack_up {
            let _ = writeln!(
                s,
                "  worst case (linear)     {}",
                range(st.linear_worst_case)
            );
            let _ = writeln!(
                s,
                "  RSS, mean ± 3σ          {}  (σ {}, R² {:.3}{})",
                range(c.rss().expect("stack-up")),
                show(st.sigma),
                st.r2,
                if st.trusted() {
                    ""
                } else {
                    ": not linear enough to trust"
                }
            );
        }
        if let Some([lo, hi, a, b]) = c.monte_carlo {
            let _ = writeln!(s, "  Monte Carlo, min–max    {}", range((lo, hi)));
            let _ = writeln!(
                s,
                "  Monte Carlo, ±3σ quantiles (0.135–99.865 %) {}",
                range((a, b))
            );
        }
    }
    s
}

/// Each input's share of each output's variance, largest first, as text.
pub fn describe_contributions(rows: &[Comparison], inputs: &[String]) -> String {
    let mut s = String::new();
    for c in rows {
        let Some(st) = &c.stack_up else { continue };
        let mut order: Vec<usize> = (0..inputs.len()).collect();
        order.sort_by(|&a, &b| {
            st.contributions[b]
                .abs()
                .total_cmp(&st.contributions[a].abs())
        });
        let list: Vec<String> = order
            .iter()
            .filter(|&&j| st.contributions[j].abs() >= 0.05)
            .map(|&j| format!("{} {:.1} %", inputs[j], st.contributions[j]))
            .collect();
        let _ = writeln!(
            s,
            "{} contributors (RSS, R² {:.3}): {}",
            c.output,
            st.r2,
            list.join(", ")
        );
    }
    s
}
