//! The commands of the `mc-study` executable: each file holds one command's arguments
//! (clap) and the function that does its work through the library and prints what the
//! user reads. `Command` lists them; `main.rs` parses and dispatches.

mod allocate;
mod compare;
mod converge;
mod merge;
mod paths;
mod report;
mod run;
mod simulate;
mod slurm;
mod status;
mod worst_case;

pub use allocate::{allocate, AllocateArgs};
pub use compare::{compare, CompareArgs};
pub use converge::{converge, ConvergeArgs};
pub use merge::{merge, MergeArgs};
pub use paths::{paths, PathsArgs};
pub use report::{report, ReportArgs};
pub use run::{run, RunArgs};
pub use simulate::{simulate_command, SimulateArgs};
pub use slurm::{slurm, SlurmArgs};
pub use status::{status, StatusArgs};
pub use worst_case::{worst_case, WorstCaseArgs};

/// The commands. Each one's first line is its summary in `mc-study --help`; the rest
/// shows in `mc-study <command> --help`.
#[derive(clap::Subcommand, Debug)]
pub enum Command {
    /// Run a Monte-Carlo study (or a rare-event study) into its result directory.
    ///
    /// Samples the study's parameters, simulates every sample in parallel and stores one
    /// row per sample in OUT/parts/*.parquet. Rerunning the same command resumes
    /// (completed samples are skipped); a complete unsharded run merges into
    /// OUT/results.parquet and prints the summary. Ctrl-C, SIGTERM (a scheduler's time
    /// limit, preemption or scancel) and SIGHUP stop the run after writing every finished
    /// sample, with exit status 128 + the signal's number; a second signal exits at once.
    /// A study with a `reliability` block estimates a rare out-of-spec rate instead, batch
    /// after batch (docs/reliability.md); its shards wait for each other at every batch.
    Run(RunArgs),
    /// Merge a result directory's part files and print the summary.
    ///
    /// Writes OUT/results.parquet (sorted by sample_id) and OUT/summary.json. Refuses when
    /// samples are missing, unless `--allow-partial`.
    Merge(MergeArgs),
    /// Measure the accuracy and cost of the study's fidelity, and recommend one.
    ///
    /// The nominal sample and `--samples` design samples run over a ladder (h₀ × 10, 5, 2,
    /// 1, ½; solver tolerance × 100 and ÷ 100; projection tolerance × 100; θ = 1; impacts
    /// located or not, the other way from the scene (combined projection only); the other
    /// schemes; the `fast` and `accurate` presets; the refinement window extrapolated or
    /// not, the other way from the scene, if it has one) against a reference at h₀/10,
    /// every run in parallel. Errors are in units of each output's Monte-Carlo σ when a
    /// result directory with summary.json is found (`--results`, default the study's
    /// output directory), else relative. Prints the table, writes converge.csv and the
    /// work–precision plot work-precision.svg (and .png), and recommends the cheapest
    /// fidelity under the target as a `fidelity` block.
    Converge(ConvergeArgs),
    /// Compare two runs of a study sample by sample, in units of each output's σ.
    ///
    /// Matches the samples of two result directories (or results files) by sample id, e.g.
    /// a study run at its fidelity and again at a finer one, and prints per output the
    /// median, 90th percentile and largest difference in units of the reference's
    /// Monte-Carlo σ, the samples above `--target` and five times it, and each run's
    /// median steps and time a sample. `converge` judges a fidelity on a few samples; this
    /// finds the samples whose course changes with the step. With `--check` the exit
    /// status is 1 when a sample is above the target.
    Compare(CompareArgs),
    /// Write the self-contained HTML report of a result directory.
    ///
    /// One page, OUT/report/report.html (figures inlined as SVG, no network), with the
    /// summary, histograms with the fitted normal and ±3σ, empirical CDFs, scatter plots
    /// against every input, SRC/SRRC (and Sobol' indices with bootstrap intervals for
    /// `design: saltelli`), running statistics and run health; each figure also as SVG
    /// and PNG in OUT/report/figures/.
    Report(ReportArgs),
    /// Tell which shards of a result directory are done, running, partial or missing.
    ///
    /// A shard is running while another process holds it. Lists the failures and the
    /// `--array=` list to resubmit.
    Status(StatusArgs),
    /// Write (and submit) the Slurm job array of a study.
    ///
    /// Writes OUT/slurm/array.sbatch (task i runs shard i/N into the shared OUT) and
    /// merge.sbatch (the merge, to run after all tasks) and, with --submit, submits both
    /// (the merge with --dependency=afterany). OUT must be on a filesystem every node sees.
    Slurm(SlurmArgs),
    /// Search each output's extremes within the tolerances, and compare with RSS and MC.
    ///
    /// Searches each output's smallest and largest value over the box of the tolerances
    /// (a `tolerance`'s band, a bounded distribution's support, or ±3σ): the centre and
    /// every corner (all of them up to 12 inputs), then a compass search from the best
    /// ones, since a mechanism's extreme need not be at a corner. Runs go in parallel into
    /// <results>/worst-case/ (resumable). Prints the extremes and the inputs that reach
    /// them, and beside the study's results: the linear worst case, the RSS prediction
    /// (mean ± 3σ, with R²), the Monte-Carlo range, which break the limits, and each
    /// input's share of the variance (docs/tolerancing.md).
    WorstCase(WorstCaseArgs),
    /// Allocate tolerances: the widths of least cost that meet a Cpk or ppm target.
    ///
    /// Each parameter's `cost` (default 1/t) is summed, and every output with limits must
    /// reach the study's `allocation` target (Cpk, or ppm through the normal model).
    /// Starts from the study's results (running it first if needed), reweights them to
    /// try tolerances without new runs, confirms each allocation with a study in
    /// <results>/allocation/round-N, and writes the allocated study beside the study file
    /// (STUDY.allocated.yaml). Exit status 3 when the target cannot be met.
    Allocate(AllocateArgs),
    /// List every parameter path of a scene, with its unit and value.
    ///
    /// The paths are the numbers a study or `--set` can vary. A value the scene leaves out
    /// is shown in parentheses: the default that applies, or the rule that gives it.
    Paths(PathsArgs),
    /// Run one simulation of a scene and print its diagnostics and probes.
    ///
    /// Prints the steps, penetration, solver and Newton failures, work and wall time per
    /// step, and the probes; on request writes the trajectory and draws the mechanism.
    Simulate(SimulateArgs),
}

impl Command {
    /// Does the command's work; `Ok(Some(status))` for a run that ends with an exit status
    /// of its own (a stop signal, a target not met).
    pub fn execute(&self) -> Result<Option<u8>> {
        let done = |r: Result<()>| r.map(|()| None);
        match self {
            Command::Run(args) => run(args),
            Command::Merge(args) => done(merge(args)),
            Command::Converge(args) => done(converge(args)),
            Command::Compare(args) => compare(args),
            Command::Report(args) => done(report(args)),
            Command::Status(args) => done(status(args)),
            Command::Slurm(args) => done(slurm(args)),
            Command::WorstCase(args) => worst_case(args),
            Command::Allocate(args) => allocate(args),
            Command::Paths(args) => done(paths(args)),
            Command::Simulate(args) => done(simulate_command(args)),
        }
    }
}

use anyhow::{bail, Context, Result};

/// A rayon pool of `threads` workers (default: all cores).
pub fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    check_threads(threads)?;
    let mut b = rayon::ThreadPoolBuilder::new();
    if let Some(t) = threads {
        b = b.num_threads(t);
    }
    b.build().context("starting the worker threads")
}

/// More worker threads than this is a typo, not a machine.
pub const MAX_THREADS: usize = 4096;

/// Refuses a thread count of 0 or beyond [`MAX_THREADS`].
pub fn check_threads(threads: Option<usize>) -> Result<()> {
    match threads {
        Some(t) if t == 0 || t > MAX_THREADS => {
            bail!("--threads {t}: give a number from 1 to {MAX_THREADS} (default: all cores)")
        }
        _ => Ok(()),
    }
}
