//! `mc-study allocate`: the tolerances of least cost that meet the study's Cpk target,
//! confirmed by a study at those tolerances, and written as a study file.

use super::check_threads;
use super::worst_case::results_of;
use crate::study::runner::RunOptions;
use crate::study::stop_signals::StopSignals;
use crate::study::summary::write_columns;
use crate::study::Study;
use crate::tolerancing::allocation_run::{allocate as run_allocation, Allocation, Ended};
use anyhow::{bail, Result};
use std::fmt::Write;
use std::path::PathBuf;

/// `mc-study allocate` arguments.
#[derive(clap::Args, Debug)]
pub struct AllocateArgs {
    /// Study YAML file, with parameters written as `tolerance` and an `allocation` block
    /// (or `--cpk` / `--ppm`).
    pub study: PathBuf,
    /// The study's results, the first round's samples (default: the study's output
    /// directory; the study is run first if they are incomplete).
    #[arg(long)]
    pub results: Option<PathBuf>,
    /// Target Cpk of every output with limits (overrides the study's `allocation`).
    #[arg(long, conflicts_with = "ppm")]
    pub cpk: Option<f64>,
    /// Target out-of-spec rate in ppm, through the normal model (overrides the study's).
    #[arg(long)]
    pub ppm: Option<f64>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// No progress lines.
    #[arg(long)]
    pub quiet: bool,
}

/// Runs the allocation; `Ok(Some(status))` when a stop signal came.
pub fn allocate(args: &AllocateArgs) -> Result<Option<u8>> {
    let study = Study::load(&args.study, None)?;
    check_threads(args.threads)?;
    let mut target = match &study.allocation {
        Some(t) => t.clone(),
        None => {
            // every output with limits
            let outputs: Vec<usize> = (0..study.outputs.len())
                .filter(|&k| study.outputs[k].lower.is_some() || study.outputs[k].upper.is_some())
                .collect();
            if outputs.is_empty() {
                bail!(
                    "{}: allocation needs outputs with `limits`",
                    args.study.display()
                );
            }
            crate::study::AllocationTarget {
                cpk: f64::NAN,
                ppm: None,
                outputs,
                narrowest: 0.1,
                widest: 4.0,
            }
        }
    };
    if let Some(c) = args.cpk {
        if !(c > 0.0 && c.is_finite()) {
            bail!("--cpk must be > 0, got {c}");
        }
        target.cpk = c;
        target.ppm = None;
    }
    if let Some(p) = args.ppm {
        if !(p > 0.0 && p < 1e6) {
            bail!("--ppm must lie in (0, 1000000), got {p}");
        }
        target.cpk = -crate::study::statistics::probit(p * 1e-6) / 3.0;
        target.ppm = Some(p);
    }
    if target.cpk.is_nan() {
        bail!("{}: give the target: an `allocation: {{ cpk: 1.33 }}` block in the study, or --cpk / --ppm", args.study.display());
    }
    let results = args
        .results
        .clone()
        .or_else(|| results_of(&study, None))
        .unwrap_or_else(|| study.output_dir.clone());
    let mut opts = RunOptions::new(results.clone());
    opts.threads = args.threads;
    opts.progress = !args.quiet;
    let signals = StopSignals::listen(opts.stop.clone())?;
    eprintln!(
        "allocating the tolerances of {} for Cpk ≥ {:.3}{} on {} output(s), from {}",
        study.name,
        target.cpk,
        target.ppm.map_or(String::new(), |p| format!(" ({p} ppm)")),
        target.outputs.len(),
        results.display()
    );
    let start = std::time::Instant::now();
    match run_allocation(&study, &args.study, &target, &results, &opts)? {
        Ended::Stopped => {
            eprintln!("stopped: every finished run is saved; rerun the same command to resume");
            Ok(Some(signals.exit_status().unwrap_or(130)))
        }
        Ended::Infeasible {
            output,
            cpk_at_narrowest,
        } => {
            println!(
                "the target cannot be met: `{output}` reaches Cpk {cpk_at_narrowest:.3} at most, with every tolerance at its narrowest ({} × today's); the other inputs or the nominal design must change",
                target.narrowest
            );
            Ok(Some(3))
        }
        Ended::Done(a) => {
            print!("{}", describe(&study, &a));
            eprintln!(
                "{} simulations in {} round(s), {:.1} s this session",
                a.simulations,
                a.rounds.len(),
                start.elapsed().as_secs_f64()
            );
            Ok(if a.met { None } else { Some(3) })
        }
    }
}

/// The allocation table and each round's confirmation.
pub fn describe(study: &Study, a: &Allocation) -> String {
    let mut s = String::new();
    let mut rows = vec![["parameter", "today", "allocated", "ratio", "cost"]
        .map(String::from)
        .to_vec()];
    for (p, &r) in study.parameters.iter().zip(&a.ratios) {
        rows.push(match &p.drawing {
            None => vec![
                p.path.clone(),
                p.stated(),
                "held: not a tolerance".into(),
                String::new(),
                String::new(),
            ],
            Some(d) => {
                let unit = p.display_unit();
                vec![
                    p.path.clone(),
                    d.describe(&unit),
                    d.scaled(r).describe(&unit),
                    format!("{r:.3}"),
                    format!("{:.2} → {:.2}", p.cost.at(1.0), p.cost.at(r)),
                ]
            }
        });
    }
    // every column left-aligned, as a drawing's tolerances read
    write_columns(&mut s, &rows, 5);
    let _ = writeln!(
        s,
        "total cost {:.3} → {:.3} ({:+.1} %)",
        a.cost_before,
        a.cost_after,
        100.0 * (a.cost_after / a.cost_before - 1.0)
    );
    for (i, r) in a.rounds.iter().enumerate() {
        let _ = writeln!(
            s,
            "round {}: predicted from {} samples (ESS {:.0}{}), confirmed by {}:",
            i + 1,
            r.samples,
            r.ess,
            if r.thin { ", thin: linear model" } else { "" },
            r.dir.display()
        );
        for (c, p) in r.confirmed.iter().zip(&r.predicted) {
            let _ = writeln!(
                s,
                "  {}: Cpk {:.3} (95 % CI {:.3}–{:.3}, predicted {:.3}), {} of {} out of spec",
                c.output, c.cpk, c.interval.0, c.interval.1, p, c.out_of_spec, c.samples
            );
        }
    }
    let last = a.rounds.last().expect("a round");
    let sure = last.confirmed.iter().all(|c| c.interval.0 >= a.target);
    let reached = last.confirmed.iter().all(|c| c.cpk >= a.target);
    let verdict = if sure {
        format!("the target Cpk {:.3} holds with 95 % confidence", a.target)
    } else if reached {
        format!("the target Cpk {:.3} holds by the estimate; its 95 % interval still reaches below it (more samples narrow it)", a.target)
    } else if a.met {
        format!("the confirmation is on the target Cpk {:.3} within its sampling error (the allocation aims at the target itself: for a margin, ask for a higher Cpk)", a.target)
    } else {
        format!(
            "the target Cpk {:.3} is NOT met after {} rounds",
            a.target,
            a.rounds.len()
        )
    };
    let _ = writeln!(s, "{verdict}; allocated study: {}", a.file.display());
    s
}
