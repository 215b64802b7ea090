//! The report of a rare-event study: the estimate with its interval and β, the tail
//! curve P(margin ≤ m) on a log axis down to the estimate, the most probable failure point
//! and how far each input moved to reach it, the subset levels, and how many simulations
//! each stage took.

use super::figures::{save, DrawResult, Figure, AXIS, BLUE, FONT, ORANGE, SMALL, TITLE};
use super::html::{esc, inline_svg, STYLE};
use super::FigureFile;
use crate::reliability::study::{load, replay_rows, summarise, RareEventSummary};
use crate::reliability::{Estimate, ImportanceSummary, Progress};
use anyhow::{bail, Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::fmt::Write;
use std::path::Path;

/// P(margin ≤ m) against m, log probability, with the estimate and its 95 % interval at
/// m = 0.
struct TailFigure<'a> {
    estimate: &'a Estimate,
}

impl Figure for TailFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        area.fill(&WHITE)?;
        let e = self.estimate;
        let band: Vec<(f64, f64, f64)> = e
            .tail
            .iter()
            .filter(|(m, p, c)| m.is_finite() && *p > 0.0 && c.is_finite())
            .map(|&(m, p, c)| {
                let (lo, hi) = crate::reliability::interval(p, c);
                (m, lo, hi)
            })
            .collect();
        let pts: Vec<(f64, f64)> = e
            .tail
            .iter()
            .map(|&(m, p, _)| (m, p))
            .filter(|(m, p)| m.is_finite() && *p > 0.0)
            .collect();
        let m1 = pts.iter().map(|p| p.0).fold(1.0, f64::max);
        let m0 = pts.iter().map(|p| p.0).fold(-0.5, f64::min);
        let p0 = pts
            .iter()
            .map(|p| p.1)
            .fold(e.interval.0.max(1e-12), f64::min)
            / 3.0;
        let mut chart = ChartBuilder::on(area)
            .caption("P(margin ≤ m)", (FONT, TITLE))
            .margin(12)
            .x_label_area_size(52)
            .y_label_area_size(88)
            .build_cartesian_2d(m0..m1, (p0..1.5).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("margin m (output's distance to its limit, in its standard deviations)")
            .y_desc("probability")
            .y_label_formatter(&|y| format!("{y:.0e}"))
            .label_style((FONT, SMALL))
            .axis_desc_style((FONT, AXIS))
            .draw()?;
        let outline: Vec<(f64, f64)> = band
            .iter()
            .map(|b| (b.0, b.2.max(p0)))
            .chain(band.iter().rev().map(|b| (b.0, b.1.max(p0))))
            .collect();
        chart
            .draw_series(std::iter::once(Polygon::new(
                outline,
                BLUE.mix(0.15).filled(),
            )))?
            .label("95 % band")
            .legend(|(x, y)| {
                Rectangle::new([(x, y - 5), (x + 14, y + 5)], BLUE.mix(0.15).filled())
            });
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), BLUE.stroke_width(2)))?
            .label("subset levels (empirical)")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 14, y)], BLUE.stroke_width(2)));
        chart.draw_series(std::iter::once(PathElement::new(
            vec![(0.0, e.interval.0.max(p0)), (0.0, e.interval.1)],
            ORANGE.stroke_width(3),
        )))?;
        for y in [e.interval.0.max(p0), e.interval.1] {
            let w = 0.02 * (m1 - m0);
            chart.draw_series(std::iter::once(PathElement::new(
                vec![(-w, y), (w, y)],
                ORANGE.stroke_width(3),
            )))?;
        }
        chart
            .draw_series(std::iter::once(Circle::new(
                (0.0, e.probability.max(p0)),
                5,
                ORANGE.filled(),
            )))?
            .label(format!("estimate ({}) with 95 % interval", e.stage))
            .legend(|(x, y)| Circle::new((x + 7, y), 4, ORANGE.filled()));
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font((FONT, SMALL))
            .position(SeriesLabelPosition::LowerRight)
            .draw()?;
        Ok(())
    }
}

/// Each input's coordinate at the most probable failure point, in standard deviations of
/// standard-normal space: the tolerances that drive the failures.
struct ShiftFigure<'a> {
    shifts: &'a [(String, f64)],
}

impl Figure for ShiftFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        area.fill(&WHITE)?;
        let top = self.shifts.iter().map(|s| s.1.abs()).fold(1.0, f64::max) * 1.15;
        let n = self.shifts.len();
        let mut chart = ChartBuilder::on(area)
            .caption("Inputs at the most probable failure", (FONT, TITLE))
            .margin(12)
            .x_label_area_size(52)
            .y_label_area_size(10)
            .build_cartesian_2d(-top..top, 0.0..n as f64)?;
        chart
            .configure_mesh()
            .disable_y_mesh()
            .disable_y_axis()
            .x_desc("shift from the median [σ]")
            .label_style((FONT, SMALL))
            .axis_desc_style((FONT, AXIS))
            .draw()?;
        chart.draw_series(self.shifts.iter().enumerate().map(|(k, (_, u))| {
            let y = (n - 1 - k) as f64;
            Rectangle::new([(0.0, y + 0.2), (*u, y + 0.8)], BLUE.mix(0.8).filled())
        }))?;
        // each input's name on the side its bar does not take
        chart.draw_series(self.shifts.iter().enumerate().map(|(k, (name, u))| {
            let y = (n - 1 - k) as f64 + 0.62;
            let x = if *u < 0.0 { 0.03 * top } else { -0.03 * top };
            let pos = if *u < 0.0 { HPos::Left } else { HPos::Right };
            Text::new(
                name.clone(),
                (x, y),
                (FONT, SMALL)
                    .into_font()
                    .into_text_style(area)
                    .pos(Pos::new(pos, VPos::Center)),
            )
        }))?;
        Ok(())
    }
}

fn page(summary: &RareEventSummary, figures: &[FigureFile], study_yaml: &str) -> Result<String> {
    let e = &summary.estimate;
    let mut s = String::new();
    writeln!(
        s,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{0} — rare event</title><style>{STYLE}</style></head><body><h1>{0}: rare event</h1>",
        esc(&summary.study)
    )?;
    let event: Vec<String> = summary
        .event
        .iter()
        .map(|(n, l, u)| {
            let l = l.map_or("−∞".to_string(), |v| format!("{v}"));
            let u = u.map_or("+∞".to_string(), |v| format!("{v}"));
            format!("{} outside [{l}, {u}]", esc(n))
        })
        .collect();
    writeln!(s, "<p>Failure: {}.</p><table>", event.join(" or "))?;
    let row = |s: &mut String, k: &str, v: String| writeln!(s, "<tr><td>{k}</td><td>{v}</td></tr>");
    if e.upper_bound {
        row(
            &mut s,
            "P(failure)",
            format!("&lt; {:.3e} (upper bound)", e.probability),
        )?;
    } else {
        row(&mut s, "P(failure)", format!("{:.3e}", e.probability))?;
        row(
            &mut s,
            "95 % interval",
            format!("{:.3e} – {:.3e}", e.interval.0, e.interval.1),
        )?;
        row(&mut s, "coefficient of variation", format!("{:.3}", e.cov))?;
        row(
            &mut s,
            "parts per million",
            format!("{:.3}", e.probability * 1e6),
        )?;
        row(
            &mut s,
            "β = −Φ⁻¹(P)",
            format!(
                "{:.3} ({:.3} – {:.3})",
                e.beta, e.beta_interval.0, e.beta_interval.1
            ),
        )?;
    }
    row(&mut s, "simulations", format!("{}", e.simulations))?;
    row(&mut s, "final figure from", e.stage.clone())?;
    row(
        &mut s,
        "failed simulations",
        format!(
            "{} (counted as {})",
            summary.failed_runs, summary.failed_samples
        ),
    )?;
    writeln!(s, "</table>")?;
    for n in &e.notes {
        writeln!(s, "<p class=\"caution\">{}</p>", esc(n))?;
    }
    writeln!(s, "<div class=\"figs\">")?;
    for f in figures {
        writeln!(
            s,
            "<figure>{}<figcaption>{}</figcaption></figure>",
            inline_svg(f)?,
            esc(&f.title)
        )?;
    }
    writeln!(s, "</div>")?;
    if let Some(p) = &summary.most_probable_failure {
        writeln!(s, "<h2>Most probable failure (run {})</h2><table><tr><th>input</th><th>value (SI)</th><th>shift [σ]</th></tr>", p.run)?;
        for (n, x, u) in &p.inputs {
            writeln!(
                s,
                "<tr><td>{}</td><td>{x:.6e}</td><td>{u:+.2}</td></tr>",
                esc(n)
            )?;
        }
        writeln!(
            s,
            "</table><table><tr><th>output</th><th>value (SI)</th></tr>"
        )?;
        for (n, y) in &p.outputs {
            writeln!(s, "<tr><td>{}</td><td>{y:.6e}</td></tr>", esc(n))?;
        }
        writeln!(s, "</table>")?;
    }
    if let Some(sub) = &e.subset {
        writeln!(s, "<h2>Subset simulation: {:.3e} (CoV {:.3}), {} simulations</h2><table><tr><th>level</th><th>conditioned on m ≤</th><th>next threshold</th><th>conditional P</th><th>CoV</th><th>chain correlation γ</th><th>acceptance</th><th>simulations</th></tr>", sub.probability, sub.cov, sub.simulations)?;
        for (j, l) in sub.levels.iter().enumerate() {
            writeln!(
                s,
                "<tr><td>{j}</td><td>{:.4}</td><td>{:.4}</td><td>{:.4}</td><td>{:.3}</td><td>{:.2}</td><td>{:.2}</td><td>{}</td></tr>",
                l.conditioned_on, l.threshold, l.probability, l.cov, l.gamma, l.acceptance, l.simulations
            )?;
        }
        writeln!(s, "</table>")?;
    }
    if let Some(ImportanceSummary {
        figures: is,
        disagreement,
    }) = &e.importance
    {
        writeln!(s, "<h2>Importance sampling: {:.3e} (CoV {:.3})</h2><p>{} simulations in {} rounds, {} failing; effective sample size {:.0}; the largest weight carries {:.1} % of the estimate; {:.1} combined standard deviations from subset simulation.</p>", is.probability, is.cov, is.simulations, is.rounds, is.failures, is.ess, 100.0 * is.largest_share, disagreement)?;
    }
    writeln!(
        s,
        "<h2>Study</h2><pre>{}</pre></body></html>",
        esc(study_yaml)
    )?;
    Ok(s)
}

/// Builds `OUT/report/report.html` for a finished rare-event study.
pub fn build(out: &Path) -> Result<super::Report> {
    let (study, rows) = load(out)?;
    let (progress, stored) = replay_rows(&study, rows, out)?;
    let Progress::Done(estimate) = progress else {
        bail!(
            "the rare-event study in {} is not finished: rerun `mc-study run` on it to go on",
            out.display()
        );
    };
    let summary = summarise(&study, *estimate, &stored)?;
    let dir = out.join("report");
    let fig_dir = dir.join("figures");
    std::fs::create_dir_all(&fig_dir).with_context(|| format!("creating {}", fig_dir.display()))?;
    let mut figures = vec![FigureFile {
        section: "rare event",
        title: "The margin's tail: the subset levels' empirical P(margin ≤ m), and the final estimate at m = 0 with its 95 % interval.".into(),
        svg: save(&TailFigure { estimate: &summary.estimate }, &fig_dir.join("tail"))?,
    }];
    if let Some(p) = &summary.most_probable_failure {
        let mut shifts: Vec<(String, f64)> =
            p.inputs.iter().map(|(n, _, u)| (n.clone(), *u)).collect();
        shifts.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
        figures.push(FigureFile {
            section: "rare event",
            title: "Which tolerances drive the failures: each input's shift from its median at the most probable failure point, in standard deviations.".into(),
            svg: save(&ShiftFigure { shifts: &shifts }, &fig_dir.join("drivers"))?,
        });
    }
    let html = page(&summary, &figures, &study.text)?;
    let path = dir.join("report.html");
    std::fs::write(&path, html).with_context(|| format!("writing {}", path.display()))?;
    Ok(super::Report {
        html: path,
        figures,
        sensitivity: Vec::new(),
        curves: Vec::new(),
    })
}
