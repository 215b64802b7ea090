//! `mc-study converge`: runs the fidelity ladder of a study in parallel and reports it.

use super::thread_pool;
use crate::integrator::StepControl;
use crate::study::converge::{sigma_of, sweep, Fidelity, Ladder};
use crate::study::sample_run::Subject;
use crate::study::summary::Summary;
use crate::study::Study;
use anyhow::{bail, Context, Result};
use std::path::PathBuf;

/// `mc-study converge` arguments.
#[derive(clap::Args, Debug)]
pub struct ConvergeArgs {
    /// Study YAML file.
    pub study: PathBuf,
    /// Where converge.csv and the plot go (default: <study output>/converge).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Design samples besides the nominal one.
    #[arg(long, default_value_t = 3)]
    pub samples: u64,
    /// Result directory whose summary.json gives the Monte-Carlo σ of each output.
    #[arg(long)]
    pub results: Option<PathBuf>,
    /// Largest accepted error: a fraction of σ (default 0.01), or of |reference| when
    /// no σ is known (then default 1e-3).
    #[arg(long)]
    pub target: Option<f64>,
    /// Fixed step sizes to try instead of the default ladder, e.g. `1e-4,5e-5,2e-5`.
    #[arg(long = "h", value_delimiter = ',')]
    pub hs: Vec<f64>,
    /// Step-control tolerances to try instead of the default ladder (adaptive steps, the
    /// scene's `step_control` settings or the defaults otherwise), e.g. `1e-3,3e-4,1e-4`;
    /// with --h, both kinds run.
    #[arg(long = "tolerances", value_delimiter = ',')]
    pub tolerances: Vec<f64>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// `mc-study converge`: the ladder's table, converge.csv, the work–precision plot and
/// the recommended fidelity.
pub fn converge(args: &ConvergeArgs) -> Result<()> {
    let study = Study::load(&args.study, None)?;
    let Subject::Mechanism(scene) = &study.subject else {
        bail!("converge needs a mechanism scene: a function scene has no fidelity to vary");
    };
    let base = Fidelity::of(&scene.params);
    let mut ladder = Ladder::around_scene(scene, args.samples);
    if !args.hs.is_empty() || !args.tolerances.is_empty() {
        for (flag, xs) in [("--h", &args.hs), ("--tolerances", &args.tolerances)] {
            if let Some(x) = xs.iter().find(|x| !(**x > 0.0 && x.is_finite())) {
                bail!("{flag}: values must be positive, got {x}");
            }
        }
        let fixed = args.hs.iter().map(|&h| Fidelity {
            h,
            step_control: None,
            ..base.clone()
        });
        let control = (scene.params.step_control.clone())
            .unwrap_or_else(|| StepControl::for_step(1e-4, scene.params.h));
        let adaptive = args.tolerances.iter().map(|&tolerance| Fidelity {
            step_control: Some(StepControl {
                tolerance,
                ..control.clone()
            }),
            ..base.clone()
        });
        ladder.fidelities = fixed.chain(adaptive).collect();
        let finest = args.hs.iter().copied().fold(f64::INFINITY, f64::min);
        ladder.reference.h = ladder.reference.h.min(finest / 2.0);
    }
    let results_dir = args
        .results
        .clone()
        .unwrap_or_else(|| study.output_dir.clone());
    let names: Vec<String> = study.outputs.iter().map(|o| o.name.clone()).collect();
    let summary = Summary::load(&results_dir)?;
    let sigma = summary.as_ref().and_then(|s| sigma_of(s, &names));
    if summary.is_some() && sigma.is_none() {
        eprintln!(
            "note: {} lacks a positive σ for some output; errors are relative instead",
            results_dir.join("summary.json").display()
        );
    }
    let target = args
        .target
        .unwrap_or(if sigma.is_some() { 0.01 } else { 1e-3 });
    if target.is_nan() || target <= 0.0 {
        bail!("--target must be positive, got {target}");
    }
    match &sigma {
        Some(_) => eprintln!(
            "σ from {}; target: error < {target} σ",
            results_dir.join("summary.json").display()
        ),
        None => eprintln!(
            "no usable summary.json in {}: errors relative to the reference; target {target}",
            results_dir.display()
        ),
    }
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| study.output_dir.join("converge"));
    check_converge_out(&dir)?;
    let total = (ladder.fidelities.len() + 1) as u64 * (1 + args.samples.min(study.runs()));
    let bar = indicatif::ProgressBar::new(total);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} runs  {msg}")
            .expect("template"),
    );
    let pool = thread_pool(args.threads)?;
    let conv = pool
        .install(|| {
            sweep(&study, &ladder, sigma, |f, sample, run| {
                bar.inc(1);
                bar.set_message(format!("{} {sample}: {:.0} ms", f.label(), run.wall_ms));
                if let Some(e) = &run.error {
                    bar.println(format!("{} {sample}: failed: {e}", f.label()));
                }
            })
        })
        .map_err(anyhow::Error::msg)?;
    bar.finish_and_clear();
    print!("{}", conv.describe(target));
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let csv = dir.join("converge.csv");
    std::fs::write(&csv, conv.csv()).with_context(|| format!("writing {}", csv.display()))?;
    let plot = crate::report::figures::save(
        &crate::report::work_precision(&conv, target),
        &dir.join("work-precision"),
    )?;
    eprintln!(
        "runs: {}; work–precision plot: {} (and .png)",
        csv.display(),
        plot.display()
    );
    let left_out = conv.left_out(target);
    let names: Vec<&str> = left_out
        .iter()
        .map(|(k, _)| conv.outputs[*k].0.as_str())
        .collect();
    let besides = match names.len() {
        0 => String::new(),
        _ => format!(" (left out, see above: {})", names.join(", ")),
    };
    match conv.recommend(target) {
        Some(f) => {
            println!(
                "cheapest fidelity with every error below {target}{}{besides}: {:.1} ms per sample",
                if conv.sigma.is_some() { " σ" } else { "" },
                conv.cost(f)
            );
            print!("{}", conv.fidelities[f].yaml());
        }
        None if left_out.len() == conv.outputs.len() => println!(
            "every output is flagged or depends on the step size (see above): no fidelity can be recommended"
        ),
        None => println!(
            "no fidelity of the ladder meets the target {target} on the outputs that converge; refine h"
        ),
    }
    Ok(())
}

/// The files `converge` writes.
const CONVERGE_FILES: [&str; 3] = ["converge.csv", "work-precision.svg", "work-precision.png"];

/// Refuses, before any run, an OUT that exists and holds anything but an earlier
/// `converge`'s files: like `run`, `converge` writes only into a new, empty or its own
/// directory.
fn check_converge_out(dir: &std::path::Path) -> Result<()> {
    if !dir.exists() {
        return Ok(());
    }
    if !dir.is_dir() {
        bail!("{} exists and is not a directory", dir.display());
    }
    let foreign: Vec<String> = std::fs::read_dir(dir)
        .with_context(|| format!("reading {}", dir.display()))?
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !CONVERGE_FILES.contains(&n.as_str()))
        .collect();
    if !foreign.is_empty() {
        bail!(
            "{} holds other files than an earlier `converge`'s ({}{}); nothing was run or written. Choose a new or empty directory.",
            dir.display(),
            foreign.iter().take(3).cloned().collect::<Vec<_>>().join(", "),
            if foreign.len() > 3 { ", …" } else { "" }
        );
    }
    Ok(())
}
