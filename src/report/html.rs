//! The report page: one HTML file with every figure inlined as SVG, the tables, the study
//! text, the fidelity and the run's health. No script, no stylesheet or image from
//! elsewhere: it opens offline in any browser.

use super::{Data, FigureFile};
use crate::study::store::{self, META_SCENE, META_STUDY, META_VERSION};
use crate::study::summary::percent;
use anyhow::{Context, Result};
use std::fmt::Write;

pub(super) fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The indented block under `key:` at the top level of a YAML text (or None).
fn yaml_block(text: &str, key: &str) -> Option<String> {
    let mut lines = text
        .lines()
        .skip_while(|l| !l.starts_with(&format!("{key}:")));
    let first = lines.next()?;
    let mut block = vec![first];
    block.extend(lines.take_while(|l| l.starts_with(' ') || l.trim().is_empty()));
    Some(block.join("\n").trim_end().to_string())
}

/// The SVG text of a figure, without an XML declaration, for inlining.
pub(super) fn inline_svg(f: &FigureFile) -> Result<String> {
    let text =
        std::fs::read_to_string(&f.svg).with_context(|| format!("reading {}", f.svg.display()))?;
    let start = text.find("<svg").unwrap_or(0);
    Ok(text[start..].to_string())
}

pub(super) const STYLE: &str =
    "body{font-family:sans-serif;margin:2em auto;max-width:1200px;color:#111;line-height:1.4}
h1{font-size:1.6em}h2{margin-top:2em;border-bottom:1px solid #ccc}
table{border-collapse:collapse;font-size:0.85em;margin:0.5em 0;display:block;max-width:100%;overflow-x:auto}
td,th{border:1px solid #ccc;padding:3px 6px;text-align:right}th{background:#eef}
td:first-child,th:first-child{text-align:left}
pre{background:#f6f6f6;padding:0.6em;overflow-x:auto;font-size:0.85em}
.figs{display:flex;flex-wrap:wrap;gap:12px}.figs figure{margin:0;width:580px}
.figs svg{width:100%;height:auto;border:1px solid #ddd}
figcaption{font-size:0.8em;color:#444}
.meta td{text-align:left}
.caution{border-left:4px solid #c60;padding:0.3em 0.8em;background:#fff6ec}";

/// Worst case, linear worst case, RSS and Monte Carlo side by side, per output.
fn tolerance_table(data: &Data) -> String {
    let mut s = String::new();
    if data
        .tolerances
        .iter()
        .all(|c| c.stack_up.is_none() && c.worst_case.is_none())
    {
        return s;
    }
    let _ = writeln!(s, "<h2>Worst case, RSS and Monte Carlo</h2><p>Worst case: the searched extremes over the tolerance box ({}). Linear: the stack-up's extremes over the same box. RSS: the stack-up's mean ± 3σ, from a regression on this study's samples; R² below 0.9 means the output is not linear enough to trust it. Monte Carlo: the sample's range, and its 0.135 % and 99.865 % quantiles. A range outside the limits is <b>marked</b>.</p>",
        if data.worst_case.is_some() { "<code>mc-study worst-case</code>" } else { "not searched yet: run <code>mc-study worst-case STUDY</code>" });
    let _ = writeln!(s, "<table><tr><th>output</th><th>limits</th><th>worst case</th><th>linear worst case</th><th>RSS ± 3σ</th><th>R²</th><th>Monte-Carlo min–max</th><th>Monte-Carlo 0.135–99.865 %</th></tr>");
    for c in &data.tolerances {
        let Some(o) = data.summary.output(&c.output) else {
            continue;
        };
        let range = |r: Option<(f64, f64)>| match r {
            None => "–".to_string(),
            Some((a, b)) => {
                let t = format!("[{}, {}]", o.show(a), o.show(b));
                if c.breaks((a, b)) {
                    format!("<b>{t}</b>")
                } else {
                    t
                }
            }
        };
        let limits = format!(
            "[{}, {}]",
            c.lower.map_or("−∞".into(), |v| o.show(v)),
            c.upper.map_or("∞".into(), |v| o.show(v))
        );
        let _ = writeln!(
            s,
            "<tr><td>{} [{}]</td><td>{limits}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(&c.output),
            esc(&o.display_unit),
            range(c.worst_case),
            range(c.stack_up.as_ref().map(|st| st.linear_worst_case)),
            range(c.rss()),
            c.stack_up.as_ref().map_or("–".into(), |st| format!("{:.3}", st.r2)),
            range(c.monte_carlo.map(|m| (m[0], m[1]))),
            range(c.monte_carlo.map(|m| (m[2], m[3]))),
        );
    }
    let _ = writeln!(s, "</table>");
    s
}

pub fn page(data: &Data, figures: &[FigureFile]) -> Result<String> {
    let t = &data.table;
    let meta = |k: &str| t.metadata.get(k).cloned().unwrap_or_default();
    let study_yaml = meta(META_STUDY);
    let scene_yaml = meta(META_SCENE);
    let mut s = String::new();
    header(&mut s, data, &study_yaml, &scene_yaml);
    inputs_section(&mut s, data, &study_yaml);
    summary_section(&mut s, data);
    sensitivity_section(&mut s, data);
    s.push_str(&tolerance_table(data));
    figure_sections(&mut s, data, figures)?;
    let _ = writeln!(
        s,
        "<h2>Study file</h2><pre>{}</pre><h2>Scene file</h2><pre>{}</pre></body></html>",
        esc(&study_yaml),
        esc(&scene_yaml)
    );
    Ok(s)
}

/// How many samples are ok, suspect and failed.
fn counts(t: &store::Table) -> (usize, usize, usize) {
    let suspect = t.rows.iter().filter(|r| r.suspect.is_some()).count();
    let failed = t.rows.iter().filter(|r| r.failed()).count();
    (t.rows.len() - failed - suspect, suspect, failed)
}

/// The page's head, its title, the study's facts and its fidelity.
fn header(s: &mut String, data: &Data, study_yaml: &str, scene_yaml: &str) {
    let (t, m) = (&data.table, &data.manifest);
    let version = t.metadata.get(META_VERSION).cloned().unwrap_or_default();
    let (ok, suspect, failed) = counts(t);
    let wall_ms: f64 = t.rows.iter().map(|r| r.diagnostics.wall_ms).sum();
    let _ = write!(
        s,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>mc-study report: {}</title><style>{STYLE}</style></head><body>\n",
        esc(&m.study_name)
    );
    let _ = writeln!(s, "<h1>Study <code>{}</code></h1>", esc(&m.study_name));
    let _ = writeln!(s, "<table class=\"meta\">");
    for (k, v) in [
        ("tool", esc(&version)),
        (
            "design",
            format!("{}, seed {}, {} runs", esc(&m.design), m.seed, m.runs),
        ),
        (
            "samples",
            format!(
                "{ok} ok, {suspect} suspect, {failed} failed{}",
                if data.missing.is_empty() {
                    String::new()
                } else {
                    format!(
                        ", <b>{} missing</b> ({})",
                        data.missing.count(),
                        esc(&data.missing.describe(8))
                    )
                }
            ),
        ),
        (
            "wall time",
            format!(
                "{:.1} s of simulation in all, {:.2} ms per sample (one core each)",
                wall_ms / 1e3,
                wall_ms / t.rows.len().max(1) as f64
            ),
        ),
        ("study hash", format!("<code>{}</code>", esc(&m.study_hash))),
        ("results", esc(&data.out.display().to_string())),
    ] {
        let _ = writeln!(s, "<tr><th>{k}</th><td>{v}</td></tr>");
    }
    let _ = writeln!(s, "</table>");
    let fidelity = [
        yaml_block(scene_yaml, "integrator").map(|b| format!("# scene\n{b}")),
        yaml_block(study_yaml, "fidelity").map(|b| format!("# study (overrides)\n{b}")),
    ]
    .into_iter()
    .flatten()
    .collect::<Vec<_>>();
    let _ = writeln!(
        s,
        "<h3>Fidelity</h3><pre>{}</pre>",
        if fidelity.is_empty() {
            "engine defaults (see src/integrator/params.rs)".to_string()
        } else {
            esc(&fidelity.join("\n"))
        }
    );
}

/// The inputs as stated, and their correlations.
fn inputs_section(s: &mut String, data: &Data, study_yaml: &str) {
    if !data.summary.inputs.is_empty() {
        let _ = writeln!(
            s,
            "<h2>Inputs</h2><table><tr><th>parameter</th><th>as stated</th></tr>"
        );
        for i in &data.summary.inputs {
            let _ = writeln!(
                s,
                "<tr><td>{}</td><td>{}</td></tr>",
                esc(&i.name),
                esc(&i.stated)
            );
        }
        let _ = writeln!(s, "</table>");
        if let Some(c) = yaml_block(study_yaml, "correlations") {
            let _ = writeln!(
                s,
                "<p>Correlated through a Gaussian copula:</p><pre>{}</pre>",
                esc(&c)
            );
        }
    }
}

/// The summary table, each output in its display unit.
fn summary_section(s: &mut String, data: &Data) {
    let _ = writeln!(s, "<h2>Summary</h2><table><tr><th>output</th><th>unit</th><th>n</th><th>failed</th><th>mean</th><th>95 % CI of mean</th><th>σ</th><th>min</th><th>1 %</th><th>5 %</th><th>50 %</th><th>95 %</th><th>99 %</th><th>max</th><th>out of spec (Wilson 95 %)</th><th>Cp / Cpk</th></tr>");
    for o in &data.summary.outputs {
        let n = match o.missing {
            0 => o.count.to_string(),
            m => format!("{} ({m} without a value)", o.count),
        };
        if o.constant {
            let _ = writeln!(
                s,
                "<tr><td>{}</td><td>{}</td><td>{n}</td><td>{}</td><td>{}</td><td colspan=\"11\" style=\"text-align:left\">constant: every sample gives this value, to round-off</td></tr>",
                esc(&o.name),
                esc(&o.display_unit),
                o.failed,
                o.show(o.mean),
            );
            continue;
        }
        let num = |v: f64| o.show(v);
        let q: Vec<String> = o.quantiles.iter().map(|(_, v)| num(*v)).collect();
        let spec = match &o.out_of_spec {
            Some(x) => format!(
                "{} = {} % ({}–{} %)",
                x.count,
                percent(x.fraction),
                percent(x.wilson95.0),
                percent(x.wilson95.1)
            ),
            None => "–".into(),
        };
        let cap = match (o.cp, o.cpk) {
            (Some(a), Some(b)) => format!("{a:.2} / {b:.2}"),
            (None, Some(b)) => format!("– / {b:.2}"),
            _ if o.out_of_spec.is_some() && o.count > 1 => "– (constant: no spread)".into(),
            _ => "–".into(),
        };
        let _ = writeln!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{n}</td><td>{}</td><td>{}</td><td>[{}, {}]</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{spec}</td><td>{cap}</td></tr>",
            esc(&o.name),
            esc(&o.display_unit),
            o.failed,
            num(o.mean),
            num(o.mean_ci95.0),
            num(o.mean_ci95.1),
            num(o.sd),
            num(o.min),
            q[0], q[1], q[2], q[3], q[4],
            num(o.max),
        );
    }
    let _ = writeln!(s, "</table>");
    for o in data.summary.outputs.iter() {
        if let Some(c) = &o.caution {
            let _ = writeln!(
                s,
                "<p class=\"caution\"><b>{}</b> depends on the step size: {}</p>",
                esc(&o.name),
                esc(c)
            );
        }
    }
}

/// The sensitivity tables.
fn sensitivity_section(s: &mut String, data: &Data) {
    let (t, m) = (&data.table, &data.manifest);
    let inputs: Vec<&str> = t.columns.inputs.iter().map(|(n, _)| n.as_str()).collect();
    let _ = writeln!(s, "<h2>Sensitivity</h2><p>SRC: standardised regression coefficients of a linear model of the output on the inputs; SRC² is the share of variance of input j when the model fits (R² near 1). SRRC: the same on ranks. Pearson / Spearman: correlations.{}</p>",
        if m.design == "saltelli" { " Sobol' indices: first order (Saltelli 2010) and total (Jansen), bootstrap 95 % intervals." } else { " Sobol' indices need <code>design: saltelli</code>." });
    let _ = write!(s, "<table><tr><th>output</th><th>measure</th>");
    for i in &inputs {
        let _ = write!(s, "<th>{}</th>", esc(i));
    }
    let _ = writeln!(s, "<th>R²</th></tr>");
    for (k, sens) in data.sensitivity.iter().enumerate() {
        let name = &t.columns.outputs[k].0;
        let mut row = |label: &str, values: Vec<String>, r2: String| {
            let _ = write!(s, "<tr><td>{}</td><td>{label}</td>", esc(name));
            for v in values {
                let _ = write!(s, "<td>{v}</td>");
            }
            let _ = writeln!(s, "<td>{r2}</td></tr>");
        };
        let corr = |f: &dyn Fn(&crate::study::summary::Correlation) -> f64| -> Vec<String> {
            inputs
                .iter()
                .map(|i| {
                    data.summary
                        .correlations
                        .iter()
                        .find(|c| c.input == *i && &c.output == name)
                        .map(f)
                        .filter(|v| v.is_finite())
                        .map_or("–".into(), |v| format!("{v:.3}"))
                })
                .collect()
        };
        row("Pearson", corr(&|c| c.pearson), String::new());
        row("Spearman", corr(&|c| c.spearman), String::new());
        let fmt = |v: &f64| {
            if v.is_finite() {
                format!("{v:.3}")
            } else {
                "–".into()
            }
        };
        if let Some((c, r2)) = &sens.src {
            row("SRC", c.iter().map(fmt).collect(), format!("{r2:.3}"));
        }
        if let Some((c, r2)) = &sens.srrc {
            row("SRRC", c.iter().map(fmt).collect(), format!("{r2:.3}"));
        }
        let e = |x: &crate::study::sensitivity::Estimate| {
            if x.value.is_finite() {
                format!("{:.3} [{:.3}, {:.3}]", x.value, x.ci95.0, x.ci95.1)
            } else {
                "–".into()
            }
        };
        if let Some(f) = &sens.first_order {
            row(
                "S (rank, from the samples)",
                f.iter().map(e).collect(),
                String::new(),
            );
        }
        if let Some(h) = &sens.hsic {
            row(
                "HSIC R² (p)",
                h.iter()
                    .map(|d| format!("{:.3} ({:.2})", d.r2, d.p_value))
                    .collect(),
                String::new(),
            );
        }
        if let Some(sob) = &sens.sobol {
            row("Sobol' S", sob.first.iter().map(e).collect(), String::new());
            row(
                "Sobol' ST",
                sob.total.iter().map(e).collect(),
                String::new(),
            );
        }
    }
    let _ = writeln!(s, "</table>");
}

/// The figures, section by section, with the run-health counts.
fn figure_sections(s: &mut String, data: &Data, figures: &[FigureFile]) -> Result<()> {
    let t = &data.table;
    let (_, suspect, failed) = counts(t);
    for (section, title, intro) in [
        ("tolerances", "Contributors", "Each input's share of the output's variance in the linear stack-up, largest first (a Pareto chart). Trust it where R² is near 1."),
        ("curves", "Curves", "Each sample's curve on its grid: the pointwise median and 5–95 % band over the samples that went through, the nominal run (every input at its median) and the measured points where the scene gives a <code>reference</code>. A grid point's value is the mean of y while x is within half a grid step of it."),
        ("distributions", "Distributions", "Histogram with the fitted normal, the mean, mean ± 3σ and the specification limits; empirical CDF."),
        ("sensitivity", "Sensitivity figures", ""),
        ("scatter", "Outputs against inputs", ""),
        ("convergence", "Convergence", "Running mean with its 95 % band and running σ against the number of samples, in sample order."),
        ("health", "Run health", "Per-sample diagnostics of the integrator."),
    ] {
        let figs: Vec<&FigureFile> = figures.iter().filter(|f| f.section == section).collect();
        if figs.is_empty() && section != "health" {
            continue;
        }
        let _ = writeln!(s, "<h2>{title}</h2>");
        if !intro.is_empty() {
            let _ = writeln!(s, "<p>{intro}</p>");
        }
        if section == "curves" {
            super::curves::section(s, &data.curves);
        }
        if section == "health" {
            let _ = writeln!(s, "<p>{failed} of {} samples failed.</p>", t.rows.len());
            if !data.summary.failures.is_empty() {
                let _ = writeln!(s, "<table><tr><th>reason</th><th>samples</th></tr>");
                for (reason, n) in &data.summary.failures {
                    let _ = writeln!(s, "<tr><td>{}</td><td>{n}</td></tr>", esc(reason));
                }
                let _ = writeln!(s, "</table>");
            }
            if suspect > 0 {
                let _ = writeln!(
                    s,
                    "<p>{suspect} samples are suspect: their runs went through with a fault, and their values are in the statistics.</p><table><tr><th>reason</th><th>samples</th></tr>"
                );
                for (reason, n) in &data.summary.suspicions {
                    let _ = writeln!(s, "<tr><td>{}</td><td>{n}</td></tr>", esc(reason));
                }
                let _ = writeln!(s, "</table>");
            }
            let nonconv: u64 = t.rows.iter().map(|r| r.diagnostics.nonconverged_steps).sum();
            let with: usize = t
                .rows
                .iter()
                .filter(|r| r.diagnostics.nonconverged_steps > 0)
                .count();
            let _ = writeln!(
                s,
                "<p>{nonconv} non-converged steps in {with} samples (counted, never accepted silently).</p>"
            );
        }
        let _ = writeln!(s, "<div class=\"figs\">");
        for f in figs {
            let _ = writeln!(
                s,
                "<figure>{}<figcaption>{} — <code>figures/{}</code> (.svg, .png)</figcaption></figure>",
                inline_svg(f)?,
                esc(&f.title),
                esc(&f.svg.file_stem().unwrap_or_default().to_string_lossy())
            );
        }
        let _ = writeln!(s, "</div>");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::yaml_block;

    #[test]
    fn yaml_block_takes_the_indented_lines() {
        let text =
            "name: x\nintegrator:\n  h: 10 us\n  solver: { tolerance: 1e-6 }\nbodies:\n  - a\n";
        assert_eq!(
            yaml_block(text, "integrator").unwrap(),
            "integrator:\n  h: 10 us\n  solver: { tolerance: 1e-6 }"
        );
        assert_eq!(yaml_block(text, "fidelity"), None);
    }
}
