//! `mc-study worst-case`: each output's extremes over the tolerance box, printed beside the
//! linear stack-up and the Monte-Carlo range of the study's results, when it has them.

use super::check_threads;
use crate::study::merge::collect;
use crate::study::runner::RunOptions;
use crate::study::stop_signals::StopSignals;
use crate::study::summary::Summary;
use crate::study::tolerance::BOX_SIGMAS;
use crate::study::Study;
use crate::tolerancing::table::{compare, describe, describe_contributions};
use crate::tolerancing::worst_case::Settings;
use crate::tolerancing::worst_case_run::{self, WorstCase};
use anyhow::{bail, Result};
use std::path::{Path, PathBuf};

/// `mc-study worst-case` arguments.
#[derive(clap::Args, Debug)]
pub struct WorstCaseArgs {
    /// Study YAML file.
    pub study: PathBuf,
    /// The study's Monte-Carlo results, for the side-by-side table (default: the study's
    /// output directory, if it holds results).
    #[arg(long)]
    pub results: Option<PathBuf>,
    /// Where the search's runs go (default: <results>/worst-case). Changing the settings
    /// below needs a new directory.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Half-width of the box of an unbounded input, in σ (a `tolerance` uses its band, a
    /// bounded distribution its support).
    #[arg(long, default_value_t = BOX_SIGMAS)]
    pub sigmas: f64,
    /// The local search stops when its step is below this fraction of each input's box.
    #[arg(long, default_value_t = Settings::default().tolerance)]
    pub tolerance: f64,
    /// Local searches per output and sense, from its best corners.
    #[arg(long, default_value_t = Settings::default().starts)]
    pub starts: usize,
    /// The outputs to search, repeatable (default: every output of the study).
    #[arg(long = "output", value_name = "NAME")]
    pub outputs: Vec<String>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// No progress lines.
    #[arg(long)]
    pub quiet: bool,
}

/// The results directory of `study`, if it holds runs.
pub(super) fn results_of(study: &Study, given: Option<&Path>) -> Option<PathBuf> {
    let dir = given.map_or_else(|| study.output_dir.clone(), Path::to_path_buf);
    crate::study::manifest::path(&dir).exists().then_some(dir)
}

/// Runs the worst-case search; `Ok(Some(status))` when a stop signal came.
pub fn worst_case(args: &WorstCaseArgs) -> Result<Option<u8>> {
    let study = Study::load(&args.study, None)?;
    check_threads(args.threads)?;
    if !(args.sigmas > 0.0 && args.sigmas.is_finite()) {
        bail!("--sigmas must be > 0, got {}", args.sigmas);
    }
    if !(args.tolerance > 0.0 && args.tolerance < 0.25) {
        bail!("--tolerance must lie in (0, 0.25), got {}", args.tolerance);
    }
    if args.starts == 0 {
        bail!("--starts must be at least 1");
    }
    if study.parameters.is_empty() {
        bail!(
            "{}: the study samples no parameter: there is no box to search",
            args.study.display()
        );
    }
    let mut outputs = Vec::new();
    for name in &args.outputs {
        let Some(k) = study.outputs.iter().position(|o| &o.name == name) else {
            bail!(
                "--output {name}: not an output of the study ({})",
                study
                    .outputs
                    .iter()
                    .map(|o| o.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        };
        if !outputs.contains(&k) {
            outputs.push(k);
        }
    }
    if outputs.is_empty() {
        outputs = (0..study.outputs.len()).collect();
    }
    let results = results_of(&study, args.results.as_deref());
    if let (Some(given), None) = (&args.results, &results) {
        bail!(
            "{}: no results there (no manifest.json): run the study into it first",
            given.display()
        );
    }
    let out = args.out.clone().unwrap_or_else(|| {
        worst_case_run::directory(results.as_deref().unwrap_or(&study.output_dir))
    });
    let settings = Settings {
        tolerance: args.tolerance,
        starts: args.starts,
        ..Settings::default()
    };
    let mut opts = RunOptions::new(out.clone());
    opts.threads = args.threads;
    opts.progress = !args.quiet;
    let signals = StopSignals::listen(opts.stop.clone())?;
    eprintln!(
        "worst case of {} over the tolerance box ({} inputs) → {}",
        study.name,
        study.parameters.len(),
        out.display()
    );
    let start = std::time::Instant::now();
    let Some(wc) = worst_case_run::run(&study, &outputs, &settings, args.sigmas, &opts)? else {
        eprintln!("stopped: every finished run is saved; rerun the same command to resume");
        return Ok(Some(signals.exit_status().unwrap_or(130)));
    };
    let merged = match &results {
        Some(dir) => Some((collect(dir)?.1, Summary::load(dir)?)),
        None => None,
    };
    let summary = merged.as_ref().and_then(|(_, s)| s.clone());
    print!("{}", describe_extremes(&study, &wc, summary.as_ref()));
    let rows = compare(
        &study,
        merged
            .as_ref()
            .and_then(|(t, s)| s.as_ref().map(|s| (t, s))),
        Some(&wc),
    );
    println!();
    print!("{}", describe(&rows, summary.as_ref()));
    let inputs: Vec<String> = study.parameters.iter().map(|p| p.path.clone()).collect();
    print!("{}", describe_contributions(&rows, &inputs));
    if summary.is_none() {
        eprintln!(
            "(no merged Monte-Carlo results at {}: run the study for the RSS and Monte-Carlo columns)",
            results.as_deref().unwrap_or(&study.output_dir).display()
        );
    }
    eprintln!(
        "{} runs ({} failed), {:.1} s this session; {}",
        wc.runs,
        wc.failed_runs,
        start.elapsed().as_secs_f64(),
        out.join("worst-case.json").display()
    );
    Ok(None)
}

/// Each output's extremes with the inputs that reach them.
fn describe_extremes(study: &Study, wc: &WorstCase, summary: Option<&Summary>) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(s, "box searched:");
    for (p, (lo, hi)) in study.parameters.iter().zip(&wc.boxes) {
        let u = p.display_unit();
        let _ = writeln!(
            s,
            "  {:30} [{:.6}, {:.6}] {}   {}",
            p.path,
            u.of(*lo),
            u.of(*hi),
            u.label,
            p.stated()
        );
    }
    for (name, e) in wc.outputs.iter().zip(&wc.extremes) {
        let o = study
            .outputs
            .iter()
            .find(|o| &o.name == name)
            .expect("a study output");
        let show = |v: f64| match summary.and_then(|m| m.output(&o.name)) {
            Some(m) => format!("{} {}", m.show(v), m.display_unit),
            None => format!("{v:.6e} {}", o.unit),
        };
        for (label, x) in [("min", &e.min), ("max", &e.max)] {
            let Some(x) = x else {
                let _ = writeln!(s, "{} {label}: every run failed", o.name);
                continue;
            };
            let at: Vec<String> = study
                .parameters
                .iter()
                .zip(&x.inputs)
                .map(|(p, v)| {
                    let u = p.display_unit();
                    format!("{}={:.6}{}", p.path, u.of(*v), u.label)
                })
                .collect();
            let place = if x.at_corner {
                "at a corner".to_string()
            } else {
                format!(
                    "off the corners, {:.3e} {} beyond the best one ({})",
                    (x.value - x.best_corner).abs(),
                    o.unit,
                    show(x.best_corner)
                )
            };
            let _ = writeln!(
                s,
                "{} {label} {} {place}, at {}",
                o.name,
                show(x.value),
                at.join(", ")
            );
        }
    }
    s
}
