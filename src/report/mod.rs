//! `mc-study report OUT`: one self-contained HTML page (`OUT/report/report.html`, figures
//! inlined as SVG, no network) plus an SVG and a PNG per figure in `OUT/report/figures/`,
//! and the sensitivity indices in `OUT/report/sensitivity.json`.

pub mod curves;
pub mod figures;
mod html;
mod rare_event;

use crate::input::units::DisplayUnit;
use crate::study::converge::Convergence;
use crate::study::given_data::{dependence, first_order, Dependence};
use crate::study::manifest::{Manifest, Ranges};
use crate::study::merge::collect;
use crate::study::sensitivity::{sobol_indices, src, srrc, Estimate, Regression, SobolIndices};
use crate::study::store::{self, Table};
use crate::study::summary::Summary;
use crate::tolerancing::table::{compare, Comparison};
use crate::tolerancing::worst_case_run::{self, WorstCase};
use anyhow::{bail, Context, Result};
use figures::{
    save, BarSeries, BarsFigure, ConvergenceFigure, EcdfFigure, HistogramFigure,
    LogHistogramFigure, ScatterFigure,
};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// The work–precision diagram of a `converge` sweep: every output's error against the
/// cost, per fidelity, with the target.
pub fn work_precision(conv: &Convergence, target: f64) -> figures::WorkPrecisionFigure {
    let n = conv.fidelities.len() - 1;
    figures::WorkPrecisionFigure {
        title: "work–precision: error against cost per fidelity".into(),
        y_desc: if conv.sigma.is_some() {
            "error / Monte-Carlo σ".into()
        } else {
            "relative error".into()
        },
        series: conv
            .outputs
            .iter()
            .enumerate()
            .filter(|(k, _)| !conv.constant(*k))
            .map(|(k, (name, _))| {
                let pts = (0..n)
                    .map(|f| figures::WorkPoint {
                        cost: conv.cost(f),
                        error: conv.error(f, k),
                        adaptive: conv.fidelities[f].step_control.is_some(),
                    })
                    .collect();
                (name.clone(), pts)
            })
            .collect(),
        target,
    }
}

/// Seed of the bootstrap of the Sobol' intervals (fixed: a report is reproducible).
const BOOTSTRAP_SEED: u64 = 2026;

/// Sensitivity of one output.
#[derive(Clone, Debug, Serialize)]
pub struct OutputSensitivity {
    pub output: String,
    /// SRC per input and R², from the design's independent rows.
    pub src: Option<(Vec<f64>, f64)>,
    pub srrc: Option<(Vec<f64>, f64)>,
    /// With a Saltelli design.
    pub sobol: Option<SobolIndices>,
    /// First-order indices from the samples of any other design (the rank estimator),
    /// with their 95 % intervals.
    pub first_order: Option<Vec<Estimate>>,
    /// HSIC dependence per input.
    pub hsic: Option<Vec<Dependence>>,
}

/// A figure of the report: its title, its section and its SVG file.
pub struct FigureFile {
    pub section: &'static str,
    pub title: String,
    pub svg: PathBuf,
}

/// What `report` wrote.
pub struct Report {
    pub html: PathBuf,
    pub figures: Vec<FigureFile>,
    pub sensitivity: Vec<OutputSensitivity>,
    /// The curves, with their comparisons against measured points.
    pub curves: Vec<curves::CurveView>,
}

fn to_pair(r: Option<Regression>) -> Option<(Vec<f64>, f64)> {
    r.map(|r| (r.coefficients, r.r2))
}

/// Everything the page shows, computed from the result directory.
pub(crate) struct Data {
    pub out: PathBuf,
    pub manifest: Manifest,
    pub table: Table,
    pub summary: Summary,
    pub missing: Ranges,
    pub sensitivity: Vec<OutputSensitivity>,
    /// Worst case, RSS and Monte Carlo per output.
    pub tolerances: Vec<Comparison>,
    pub worst_case: Option<WorstCase>,
    pub curves: Vec<curves::CurveView>,
}

fn column(table: &Table, f: impl Fn(&store::Row) -> f64) -> Vec<f64> {
    table.rows.iter().map(f).collect()
}

fn analyse(out: &Path) -> Result<Data> {
    crate::study::merge::refuse_search(out)?;
    let (manifest, table) = collect(out)?;
    if table.rows.is_empty() {
        bail!(
            "{} holds no samples yet: run the study first",
            out.display()
        );
    }
    let missing =
        Ranges::from_ids(table.rows.iter().map(|r| r.id).collect()).missing_in(0, manifest.runs);
    let study = crate::study::merge::stored_study(&manifest, &table)?;
    let summary = Summary::of(&manifest.study_name, &table, &study.outputs)
        .with_inputs(&study.parameters)
        .with_curves(&table, study.subject.curves());
    let d = table.columns.inputs.len();
    let saltelli = manifest.design == "saltelli";
    // rows for the regressions: the independent points (A and B blocks of Saltelli)
    let independent: Vec<&store::Row> = table
        .rows
        .iter()
        .filter(|r| !saltelli || (r.id % (d as u64 + 2)) < 2)
        .collect();
    let xs: Vec<Vec<f64>> = (0..d)
        .map(|j| independent.iter().map(|r| r.inputs[j]).collect())
        .collect();
    let sensitivity = table
        .columns
        .outputs
        .iter()
        .enumerate()
        .map(|(k, (name, _))| {
            let y: Vec<f64> = independent.iter().map(|r| r.outputs[k]).collect();
            let sobol = saltelli.then(|| {
                // by sample id, NaN where a run failed or is missing
                let mut by_id = vec![f64::NAN; manifest.runs as usize];
                for r in &table.rows {
                    by_id[r.id as usize] = r.outputs[k];
                }
                sobol_indices(&by_id, d, BOOTSTRAP_SEED)
            });
            OutputSensitivity {
                output: name.clone(),
                src: to_pair(src(&xs, &y)),
                srrc: to_pair(srrc(&xs, &y)),
                sobol: sobol.flatten(),
                first_order: (!saltelli).then(|| xs.iter().map(|x| first_order(x, &y)).collect()),
                hsic: dependence(&xs, &y, BOOTSTRAP_SEED),
            }
        })
        .collect();
    let worst_case = WorstCase::load(&worst_case_run::directory(out))?;
    let tolerances = compare(&study, Some((&table, &summary)), worst_case.as_ref());
    let curves = curves::views(out, &study, &table, &summary.curves);
    Ok(Data {
        curves,
        tolerances,
        worst_case,
        out: out.to_path_buf(),
        manifest,
        table,
        summary,
        missing,
        sensitivity,
    })
}

/// File-name-safe stem.
fn slug(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

fn short_input(name: &str) -> String {
    // "joints.J3.clearance" → "J3.clearance", "inputs.x1" → "x1"
    name.split_once('.')
        .map(|(_, rest)| rest.to_string())
        .unwrap_or_else(|| name.to_string())
}

/// At most this many points in a scatter plot and in a running-statistics curve (every
/// k-th sample beyond): the figures stay light whatever N.
const MAX_POINTS: usize = 5000;

fn thin<T: Clone>(v: &[T]) -> Vec<T> {
    let k = v.len().div_ceil(MAX_POINTS).max(1);
    v.iter().step_by(k).cloned().collect()
}

fn draw_figures(data: &Data, dir: &Path) -> Result<Vec<FigureFile>> {
    let mut out = Vec::new();
    let t = &data.table;
    let ok: Vec<&store::Row> = t.rows.iter().filter(|r| !r.failed()).collect();
    let inputs: Vec<String> = t
        .columns
        .inputs
        .iter()
        .map(|(n, _)| short_input(n))
        .collect();
    for k in 0..t.columns.outputs.len() {
        let values: Vec<f64> = ok
            .iter()
            .map(|r| r.outputs[k])
            .filter(|v| v.is_finite())
            .collect();
        if values.is_empty() {
            continue;
        }
        distribution_figures(data, k, &values, dir, &mut out)?;
        scatter_figures(data, k, &ok, &inputs, dir, &mut out)?;
        sensitivity_figures(data, k, &inputs, dir, &mut out)?;
    }
    curves::figures(&data.curves, dir, &mut out)?;
    health_figures(t, dir, &mut out)?;
    Ok(out)
}

/// Output `k`'s histogram, empirical CDF and running statistics, over its finite `values`.
fn distribution_figures(
    data: &Data,
    k: usize,
    values: &[f64],
    dir: &Path,
    out: &mut Vec<FigureFile>,
) -> Result<()> {
    let (name, s) = (&data.table.columns.outputs[k].0, &data.summary.outputs[k]);
    let scale = s.display();
    let stem = dir.join(format!("hist_{}", slug(name)));
    let svg = save(
        &HistogramFigure {
            title: format!(
                "{name}: mean {} {u}, σ {} {u}",
                s.show(s.mean),
                s.show(s.sd),
                u = scale.label
            ),
            scale: scale.clone(),
            name,
            values,
            mean: s.mean,
            sd: s.sd,
            limits: (s.lower_limit, s.upper_limit),
        },
        &stem,
    )?;
    out.push(FigureFile {
        section: "distributions",
        title: format!("{name}: histogram"),
        svg,
    });
    let svg = save(
        &EcdfFigure {
            title: format!("{name}: empirical CDF"),
            scale: scale.clone(),
            name,
            values,
        },
        &dir.join(format!("ecdf_{}", slug(name))),
    )?;
    out.push(FigureFile {
        section: "distributions",
        title: format!("{name}: empirical CDF"),
        svg,
    });
    let svg = save(
        &ConvergenceFigure {
            title: format!("{name}: running mean (95 % band) and σ"),
            scale: scale.clone(),
            name,
            values,
        },
        &dir.join(format!("conv_{}", slug(name))),
    )?;
    out.push(FigureFile {
        section: "convergence",
        title: format!("{name}: running statistics"),
        svg,
    });
    Ok(())
}

/// Output `k` against every input, over the samples `ok`.
fn scatter_figures(
    data: &Data,
    k: usize,
    ok: &[&store::Row],
    inputs: &[String],
    dir: &Path,
    out: &mut Vec<FigureFile>,
) -> Result<()> {
    let (t, name) = (&data.table, &data.table.columns.outputs[k].0);
    let scale = data.summary.outputs[k].display();
    for (j, (input, input_unit)) in t.columns.inputs.iter().enumerate() {
        let points: Vec<(f64, f64)> = thin(
            &ok.iter()
                .filter(|r| r.outputs[k].is_finite())
                .map(|r| (r.inputs[j], r.outputs[k]))
                .collect::<Vec<_>>(),
        );
        let xs: Vec<f64> = points.iter().map(|p| p.0).collect();
        let corr = data
            .summary
            .correlations
            .iter()
            .find(|c| &c.input == input && &c.output == name);
        let title = match corr {
            Some(c) if !c.pearson.is_finite() => {
                format!(
                    "{name} vs {}: one of them is constant, no correlation",
                    inputs[j]
                )
            }
            Some(c) => format!(
                "{name} vs {}: Pearson {:.2}, Spearman {:.2}",
                inputs[j], c.pearson, c.spearman
            ),
            None => format!("{name} vs {}", inputs[j]),
        };
        let svg = save(
            &ScatterFigure {
                title: title.clone(),
                x_name: &inputs[j],
                x_scale: DisplayUnit::for_values(input_unit, &xs),
                y_name: name,
                y_scale: scale.clone(),
                points: &points,
            },
            &dir.join(format!("scatter_{}_{}", slug(name), slug(input))),
        )?;
        out.push(FigureFile {
            section: "scatter",
            title,
            svg,
        });
    }
    Ok(())
}

/// Output `k`'s sensitivity bars: SRC², first-order indices from the samples, the
/// tolerances' contributions, and Sobol' indices where the design gives them.
fn sensitivity_figures(
    data: &Data,
    k: usize,
    inputs: &[String],
    dir: &Path,
    out: &mut Vec<FigureFile>,
) -> Result<()> {
    let name = &data.table.columns.outputs[k].0;
    let sens = &data.sensitivity[k];
    if let Some((src, r2)) = &sens.src {
        let svg = save(
            &BarsFigure {
                title: format!("{name}: SRC² (linear model R² = {r2:.3})"),
                y_desc: "SRC² (share of variance if linear)".into(),
                inputs: inputs.to_vec(),
                series: vec![BarSeries {
                    label: "SRC²".into(),
                    values: src.iter().map(|c| c * c).collect(),
                    intervals: None,
                }],
            },
            &dir.join(format!("src_{}", slug(name))),
        )?;
        out.push(FigureFile {
            section: "sensitivity",
            title: format!("{name}: SRC²"),
            svg,
        });
    }
    if let Some(est) = &sens.first_order {
        let svg = save(
            &BarsFigure {
                title: format!("{name}: first-order indices from the samples (rank estimator)"),
                y_desc: "S (95 % interval)".into(),
                inputs: inputs.to_vec(),
                series: vec![BarSeries {
                    label: "first order S".into(),
                    values: est.iter().map(|e| e.value).collect(),
                    intervals: Some(est.iter().map(|e| e.ci95).collect()),
                }],
            },
            &dir.join(format!("first_order_{}", slug(name))),
        )?;
        out.push(FigureFile {
            section: "sensitivity",
            title: format!("{name}: first-order indices"),
            svg,
        });
    }
    if let Some(st) = data.tolerances.get(k).and_then(|c| c.stack_up.as_ref()) {
        let mut order: Vec<usize> = (0..inputs.len()).collect();
        order.sort_by(|&a, &b| st.contributions[b].total_cmp(&st.contributions[a]));
        let svg = save(
            &BarsFigure {
                title: format!(
                    "{name}: contributors to the variance (RSS, R² = {:.3}{})",
                    st.r2,
                    if st.trusted() {
                        ""
                    } else {
                        ", not linear enough to trust"
                    }
                ),
                y_desc: "share of σ² [%]".into(),
                inputs: order.iter().map(|&j| inputs[j].clone()).collect(),
                series: vec![BarSeries {
                    label: "contribution".into(),
                    values: order.iter().map(|&j| st.contributions[j]).collect(),
                    intervals: None,
                }],
            },
            &dir.join(format!("contributors_{}", slug(name))),
        )?;
        out.push(FigureFile {
            section: "tolerances",
            title: format!("{name}: contributors"),
            svg,
        });
    }
    if let Some(sobol) = &sens.sobol {
        let svg = save(
            &BarsFigure {
                title: format!("{name}: Sobol' indices ({} base rows)", sobol.base_rows),
                y_desc: "index (bootstrap 95 % interval)".into(),
                inputs: inputs.to_vec(),
                series: vec![
                    BarSeries {
                        label: "first order S".into(),
                        values: sobol.first.iter().map(|e| e.value).collect(),
                        intervals: Some(sobol.first.iter().map(|e| e.ci95).collect()),
                    },
                    BarSeries {
                        label: "total ST".into(),
                        values: sobol.total.iter().map(|e| e.value).collect(),
                        intervals: Some(sobol.total.iter().map(|e| e.ci95).collect()),
                    },
                ],
            },
            &dir.join(format!("sobol_{}", slug(name))),
        )?;
        out.push(FigureFile {
            section: "sensitivity",
            title: format!("{name}: Sobol' indices"),
            svg,
        });
    }
    Ok(())
}

/// The run-health histograms: only meaningful for simulated samples.
fn health_figures(t: &store::Table, dir: &Path, out: &mut Vec<FigureFile>) -> Result<()> {
    let steps = column(t, |r| r.diagnostics.steps as f64);
    if steps.iter().any(|&s| s > 0.0) {
        for (label, file, values) in [
            (
                "largest penetration per sample",
                "health_penetration",
                column(t, |r| r.diagnostics.max_penetration),
            ),
            (
                "largest contact-solver residual per sample",
                "health_residual",
                column(t, |r| r.diagnostics.max_solver_residual),
            ),
        ] {
            let svg = save(
                &LogHistogramFigure {
                    title: label.to_string(),
                    x_desc: if file == "health_penetration" {
                        "log10(max penetration [m])".into()
                    } else {
                        "log10(max natural-map residual)".into()
                    },
                    values: &values,
                },
                &dir.join(file),
            )?;
            out.push(FigureFile {
                section: "health",
                title: label.to_string(),
                svg,
            });
        }
    }
    Ok(())
}

/// Builds the report of the result directory `out`.
pub fn build(out: &Path) -> Result<Report> {
    if crate::reliability::study::is_rare_event_dir(out) {
        return rare_event::build(out);
    }
    let data = analyse(out)?;
    let dir = out.join("report");
    let fig_dir = dir.join("figures");
    std::fs::create_dir_all(&fig_dir).with_context(|| format!("creating {}", fig_dir.display()))?;
    let figures = draw_figures(&data, &fig_dir)?;
    let json = serde_json::to_string_pretty(&data.sensitivity)?;
    std::fs::write(dir.join("sensitivity.json"), json)?;
    if !data.curves.is_empty() {
        let json = serde_json::to_string_pretty(&data.curves)?;
        std::fs::write(dir.join("curves.json"), json)?;
    }
    let page = html::page(&data, &figures)?;
    let path = dir.join("report.html");
    std::fs::write(&path, page).with_context(|| format!("writing {}", path.display()))?;
    Ok(Report {
        html: path,
        figures,
        sensitivity: data.sensitivity,
        curves: data.curves,
    })
}
