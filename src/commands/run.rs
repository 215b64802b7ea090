//! `mc-study run`: runs a study (or a shard of it) into its result directory, stopping
//! cleanly on a signal, and merges a complete unsharded run.

use super::check_threads;
use crate::study::merge::merge;
use crate::study::runner::{self, RunOptions, Shard};
use crate::study::stop_signals::StopSignals;
use crate::study::Study;
use anyhow::{bail, Result};
use std::path::PathBuf;

/// `mc-study run` arguments.
#[derive(clap::Args, Debug)]
pub struct RunArgs {
    /// Study YAML file (see studies/*/study.yaml).
    pub study: PathBuf,
    /// Number of samples N (overrides `samples`; for `saltelli` the base rows).
    #[arg(long)]
    pub samples: Option<u64>,
    /// Output directory (overrides the study's `output`; default results/<study name>).
    /// It must be new, empty, or a result directory of the same study.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Worker threads, 1 to 4096 (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Run only shard I of N (`I/N`); `/N` takes I from SLURM_ARRAY_TASK_ID.
    #[arg(long)]
    pub shard: Option<String>,
    /// Same as `--shard /N`.
    #[arg(long, conflicts_with = "shard")]
    pub shards: Option<u64>,
    /// No progress bar or progress lines.
    #[arg(long)]
    pub quiet: bool,
    /// Samples per part file: a crash loses at most the samples not yet in a part.
    #[arg(long, default_value_t = 1024)]
    pub part_rows: usize,
    /// Seconds after which a part is written even if not full (`inf`: only when full).
    #[arg(long, default_value_t = 30.0)]
    pub part_seconds: f64,
}

/// Runs a study; `Ok(Some(status))` when a stop signal came (the samples done are saved).
pub fn run(args: &RunArgs) -> Result<Option<u8>> {
    let shard = match (&args.shard, args.shards) {
        (Some(s), _) => Some(Shard::parse(s)?),
        (None, Some(n)) => Some(Shard::parse(&format!("/{n}"))?),
        (None, None) => None,
    };
    let study = Study::load(&args.study, args.samples)?;
    check_threads(args.threads)?;
    if args.part_rows == 0 || args.part_seconds.is_nan() || args.part_seconds <= 0.0 {
        bail!("--part-rows and --part-seconds must be positive");
    }
    let out = args.out.clone().unwrap_or_else(|| study.output_dir.clone());
    let mut opts = RunOptions::new(out.clone());
    opts.threads = args.threads;
    opts.shard = shard.unwrap_or(Shard::WHOLE);
    opts.progress = !args.quiet;
    opts.rows_per_part = args.part_rows;
    opts.seconds_per_part = args.part_seconds;
    let signals = StopSignals::listen(opts.stop.clone())?;
    for w in study.subject.warnings() {
        eprintln!("warning: {w}");
    }
    for o in &study.outputs {
        if let Some(c) = &o.caution {
            eprintln!("caution: {c}");
        }
    }
    if let Some(r) = &study.reliability {
        opts.wait_for_shards = true;
        eprintln!(
            "rare-event study {} ({} method, {} samples per level, target CoV {}, at most {} runs, seed {}), shard {}/{} → {}",
            study.name,
            r.method,
            study.design.base,
            r.target_cov,
            r.max_simulations,
            study.seed,
            opts.shard.index,
            opts.shard.count,
            out.display()
        );
        return rare_event(&study, &opts, &signals);
    }
    let (a, b) = opts.shard.range(study.runs());
    let samples = if a < b {
        format!("samples {a}–{}", b - 1)
    } else {
        "no samples (more shards than runs)".into()
    };
    eprintln!(
        "study {} ({} design, {} runs, seed {}), shard {}/{} = {samples} → {}",
        study.name,
        study.design.kind.name(),
        study.runs(),
        study.seed,
        opts.shard.index,
        opts.shard.count,
        out.display()
    );
    let r = runner::run(&study, &opts)?;
    eprintln!(
        "{} samples run ({} failed) into {} part file(s), {} already done, in {:.1} s ({:.1} samples/s)",
        r.done,
        r.failed,
        r.parts,
        r.skipped,
        r.wall_seconds,
        r.done as f64 / r.wall_seconds.max(1e-9)
    );
    if let Some(status) = signals.exit_status() {
        eprintln!("stopped: every finished sample is saved; rerun the same command to resume");
        return Ok(Some(status));
    }
    if r.interrupted {
        eprintln!("interrupted: rerun the same command to resume");
        return Ok(Some(130));
    }
    if r.missing.is_empty() && opts.shard.count == 1 {
        let m = merge(&out, false)?;
        print!("{}", m.summary);
        eprintln!(
            "results: {} ({} rows), {}",
            m.path.display(),
            m.rows,
            out.join("summary.json").display()
        );
    } else if r.missing.is_empty() {
        eprintln!(
            "all samples of the study are done: run `mc-study merge {}`",
            out.display()
        );
    } else {
        eprintln!(
            "shard done; {} samples of the study remain in other shards (`mc-study status {}`)",
            r.missing.count(),
            out.display()
        );
    }
    Ok(None)
}

/// Runs a rare-event study batch by batch, and prints its estimate when done.
fn rare_event(study: &Study, opts: &RunOptions, signals: &StopSignals) -> Result<Option<u8>> {
    use crate::reliability::study::{describe, run, Ended};
    match run(study, opts)? {
        Ended::Done(f) => {
            print!("{}", describe(&f, study));
            eprintln!(
                "results: {}, {}",
                f.results.display(),
                opts.out.join("summary.json").display()
            );
            Ok(None)
        }
        Ended::ShardDone { batch, remaining } => {
            eprintln!(
                "this shard's part of batch {batch} is done; {remaining} runs of the batch remain in other shards. When every shard has finished, rerun to go on to the next batch."
            );
            Ok(None)
        }
        Ended::Stopped => {
            eprintln!(
                "stopped: every finished simulation is saved; rerun the same command to resume"
            );
            Ok(Some(signals.exit_status().unwrap_or(130)))
        }
    }
}
