//! The report's curves: each curve's population (median and 5–95 % band), the nominal
//! run (every input at its median), and the measured points stored with the results,
//! with how far they lie from the median.

use super::figures::{save, CurveFigure};
use super::html::esc;
use super::{slug, FigureFile};
use crate::input::units::DisplayUnit;
use crate::study::curves::{stored_reference, Comparison, CurveSummary};
use crate::study::store::Table;
use crate::study::Study;
use anyhow::Result;
use serde::Serialize;
use std::fmt::Write;
use std::path::Path;

/// One curve as the report shows it.
#[derive(Clone, Debug, Serialize)]
pub struct CurveView {
    pub summary: CurveSummary,
    /// The nominal run's curve, or why there is none.
    pub nominal: Result<Vec<Option<f64>>, String>,
    /// The measured points and their comparison with the median, if the scene gives a
    /// reference (or why it could not be read).
    pub reference: Option<Result<Measured, String>>,
}

#[derive(Clone, Debug, Serialize)]
pub struct Measured {
    pub points: Vec<(f64, f64)>,
    pub comparison: Comparison,
}

/// The curves of the results in `out`: their summaries, a nominal run of `study` (only
/// when it has curves) and the references stored in `out`.
pub fn views(
    out: &Path,
    study: &Study,
    table: &Table,
    summaries: &[CurveSummary],
) -> Vec<CurveView> {
    if summaries.is_empty() {
        return Vec::new();
    }
    let nominal = study.run_inputs(&study.inputs_at_standard(&vec![0.0; study.parameters.len()]));
    summaries
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let nominal = match (&nominal.error, nominal.curves.get(k)) {
                (Some(e), _) => Err(e.clone()),
                (None, Some(v)) => Ok(v.iter().map(|y| y.is_finite().then_some(*y)).collect()),
                (None, None) => Err("the scene no longer has this curve".into()),
            };
            let reference = stored_reference(out, &table.columns.curves[k]).map(|r| {
                r.map(|points| Measured {
                    comparison: s.compare(&points),
                    points,
                })
            });
            CurveView {
                summary: s.clone(),
                nominal,
                reference,
            }
        })
        .collect()
}

/// One figure per curve.
pub fn figures(views: &[CurveView], dir: &Path, out: &mut Vec<FigureFile>) -> Result<()> {
    for v in views {
        let s = &v.summary;
        let nan = |v: Option<f64>| v.unwrap_or(f64::NAN);
        let band = (0..s.grid.count)
            .map(|i| {
                (
                    s.grid.point(i),
                    nan(s.p05[i]),
                    nan(s.median[i]),
                    nan(s.p95[i]),
                )
            })
            .collect();
        let nominal = v.nominal.as_ref().ok().map(|n| {
            n.iter()
                .enumerate()
                .map(|(i, y)| (s.grid.point(i), nan(*y)))
                .collect()
        });
        let measured = match &v.reference {
            Some(Ok(m)) => m.points.as_slice(),
            _ => &[],
        };
        let title = format!("{}: {} samples, median and 5–95 % band", s.name, s.samples);
        let svg = save(
            &CurveFigure {
                title: title.clone(),
                x_name: &s.x,
                x_scale: s.x_display(),
                y_name: &s.name,
                y_scale: s.display(),
                band,
                nominal,
                reference: measured,
            },
            &dir.join(format!("curve_{}", slug(&s.name))),
        )?;
        out.push(FigureFile {
            section: "curves",
            title,
            svg,
        });
    }
    Ok(())
}

/// The sentence that says how far the measured points lie from the median.
pub fn describe(v: &CurveView) -> Option<String> {
    let s = &v.summary;
    let (y, x) = (s.display(), s.x_display());
    let show = |u: &DisplayUnit, si: f64| {
        format!("{} {}", significant(si * u.per_si), u.label)
            .trim_end()
            .to_string()
    };
    Some(match v.reference.as_ref()? {
        Err(e) => format!(
            "curve `{}`: the measured points cannot be read: {e}",
            s.name
        ),
        Ok(m) => {
            let c = &m.comparison;
            match (c.rms, c.max_abs, c.max_at, c.in_band) {
                (Some(rms), Some(max), Some(at), Some(band)) => format!(
                    "curve `{}` against {} measured points: median off by {} RMS, at most {} (at {} = {}); {:.0} % of the points inside the 5–95 % band{}",
                    s.name,
                    c.compared,
                    show(&y, rms),
                    show(&y, max),
                    s.x,
                    show(&x, at),
                    100.0 * band,
                    if c.outside_grid > 0 {
                        let s = if c.outside_grid == 1 { "" } else { "s" };
                        format!("; {} point{s} beyond the curves left out", c.outside_grid)
                    } else {
                        String::new()
                    }
                ),
                _ => format!(
                    "curve `{}`: none of its {} measured points lies where the curves have values",
                    s.name,
                    m.points.len()
                ),
            }
        }
    })
}

/// Four significant digits, without an exponent for everyday magnitudes.
fn significant(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if (1e-3..1e5).contains(&v.abs()) {
        let digits = (3 - v.abs().log10().floor() as i32).clamp(0, 6) as usize;
        format!("{v:.digits$}")
    } else {
        format!("{v:.3e}")
    }
}

/// The page's curve section: each comparison with measured points, and why a nominal
/// run is missing where it is.
pub fn section(s: &mut String, views: &[CurveView]) {
    for v in views {
        if let Some(d) = describe(v) {
            let _ = writeln!(s, "<p>{}</p>", esc(&d));
        }
        if let Err(e) = &v.nominal {
            let _ = writeln!(
                s,
                "<p>curve <code>{}</code>: the nominal run failed: {}</p>",
                esc(&v.summary.name),
                esc(e)
            );
        }
    }
}
