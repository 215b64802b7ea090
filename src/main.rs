//! The `mc-study` command line: the commands and their options (clap), each dispatched to
//! `mc_study::commands`, which does the work through the library and prints the results.

use clap::{Parser, Subcommand};
use mc_study::commands::{
    allocate, converge, run, simulate_command, slurm, worst_case, AllocateArgs, ConvergeArgs,
    RunArgs, SimulateArgs, WorstCaseArgs,
};
use mc_study::scene::Scene;
use mc_study::study::merge::{merge, status};
use mc_study::study::runner::Shard;
use mc_study::study::slurm::SlurmOptions;
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "mc-study",
    version,
    about = "Monte-Carlo tolerance studies of mechanisms with clearances on an exact nonsmooth (Moreau–Jean) integrator",
    after_help = "Paths written in a study or scene file are relative to that file; paths given on the command line are relative to the working directory.\nGuides: README.md and docs/ in the source tree."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Runs a Monte-Carlo study: samples the study's parameters, simulates every sample in
    /// parallel and stores one row per sample in OUT/parts/*.parquet. Rerunning the same
    /// command resumes (completed samples are skipped); a complete unsharded run merges into
    /// OUT/results.parquet and prints the summary. Ctrl-C, SIGTERM (a scheduler's time limit,
    /// preemption or scancel) and SIGHUP stop the run after writing every finished sample,
    /// with exit status 128 + the signal's number; a second signal exits at once. A study
    /// with a `reliability` block estimates a rare out-of-spec rate instead, batch after
    /// batch (docs/reliability.md); its shards wait for each other at every batch.
    Run {
        /// Study YAML file (see studies/*/study.yaml).
        study: PathBuf,
        /// Number of samples N (overrides `samples`; for `saltelli` the base rows).
        #[arg(long)]
        samples: Option<u64>,
        /// Output directory (overrides the study's `output`; default results/<study name>).
        /// It must be new, empty, or a result directory of the same study.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Worker threads, 1 to 4096 (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Run only shard I of N (`I/N`); `/N` takes I from SLURM_ARRAY_TASK_ID.
        #[arg(long)]
        shard: Option<String>,
        /// Same as `--shard /N`.
        #[arg(long, conflicts_with = "shard")]
        shards: Option<u64>,
        /// No progress bar or progress lines.
        #[arg(long)]
        quiet: bool,
        /// Samples per part file: a crash loses at most the samples not yet in a part.
        #[arg(long, default_value_t = 1024)]
        part_rows: usize,
        /// Seconds after which a part is written even if not full (`inf`: only when full).
        #[arg(long, default_value_t = 30.0)]
        part_seconds: f64,
    },
    /// Merges the part files of OUT into OUT/results.parquet (sorted by sample_id), writes
    /// OUT/summary.json and prints the summary. Refuses when samples are missing.
    Merge {
        /// Result directory of a study (the `--out` of `run`).
        out: PathBuf,
        /// Merge even if samples are missing (the summary then covers those present).
        #[arg(long)]
        allow_partial: bool,
    },
    /// Measures the accuracy–cost trade of the study's fidelity: the nominal sample and
    /// `--samples` design samples run over a ladder (h₀ × 10, 5, 2, 1, ½; solver tolerance
    /// × 100 and ÷ 100; projection tolerance × 100; θ = 1; impacts located or not, the
    /// other way from the scene (combined projection only); the other schemes; the `fast`
    /// and `accurate` presets; the refinement window extrapolated or not, the other way
    /// from the scene, if it has one) against a reference at h₀/10, every run in parallel.
    /// Errors are in units of each output's Monte-Carlo σ when a result directory with
    /// summary.json is found (`--results`, default the study's output directory), else
    /// relative. Prints the table, writes converge.csv and the work–precision plot
    /// work-precision.svg (and .png), and recommends the cheapest fidelity under the target
    /// as a `fidelity` block.
    Converge {
        /// Study YAML file.
        study: PathBuf,
        /// Where converge.csv and the plot go (default: <study output>/converge).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Design samples besides the nominal one.
        #[arg(long, default_value_t = 3)]
        samples: u64,
        /// Result directory whose summary.json gives the Monte-Carlo σ of each output.
        #[arg(long)]
        results: Option<PathBuf>,
        /// Largest accepted error: a fraction of σ (default 0.01), or of |reference| when
        /// no σ is known (then default 1e-3).
        #[arg(long)]
        target: Option<f64>,
        /// Step sizes to try instead of the default ladder, e.g. `1e-4,5e-5,2e-5`.
        #[arg(long, value_delimiter = ',')]
        h: Vec<f64>,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
    },
    /// Writes OUT/report/report.html: one self-contained page (figures inlined as SVG, no
    /// network) with the summary, histograms with the fitted normal and ±3σ, empirical
    /// CDFs, scatter plots against every input, SRC/SRRC (and Sobol' indices with
    /// bootstrap intervals for `design: saltelli`), running statistics and run health;
    /// each figure also as SVG and PNG in OUT/report/figures/.
    Report {
        /// Result directory of a study (merged or not).
        out: PathBuf,
    },
    /// Tells which shards of OUT are complete, running (another process holds the shard),
    /// partial or missing, with failures, and the `--array=` list to resubmit.
    Status {
        /// Result directory of a study.
        out: PathBuf,
        /// Shard count to report on (default: that of the latest run).
        #[arg(long)]
        shards: Option<u64>,
    },
    /// Writes Slurm job-array scripts for a study into OUT/slurm/ (array.sbatch: task i
    /// runs shard i/N into the shared OUT; merge.sbatch: the merge, to run after all tasks)
    /// and, with --submit, submits both (the merge with --dependency=afterany). OUT must be
    /// on a filesystem every node sees.
    Slurm {
        /// Study YAML file.
        study: PathBuf,
        /// Number of array tasks N (shards).
        #[arg(long)]
        tasks: u64,
        /// Output directory shared by all tasks (default: the study's `output`).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Number of samples (overrides the study's `samples`).
        #[arg(long)]
        samples: Option<u64>,
        /// Slurm partition.
        #[arg(long)]
        partition: Option<String>,
        /// Time limit per task (Slurm format, e.g. 02:00:00).
        #[arg(long)]
        time: Option<String>,
        /// CPUs per task; each task runs that many worker threads (default 1).
        #[arg(long)]
        cpus_per_task: Option<u32>,
        /// Memory per task (Slurm format, e.g. 2G).
        #[arg(long)]
        mem: Option<String>,
        /// Slurm account to charge.
        #[arg(long)]
        account: Option<String>,
        /// Samples per part file written by the tasks (default 1024; smaller loses less
        /// when a task is killed or preempted).
        #[arg(long)]
        part_rows: Option<usize>,
        /// Submit the array and the merge job with sbatch and print their ids.
        #[arg(long)]
        submit: bool,
    },
    /// Searches each output's smallest and largest value over the box of the tolerances
    /// (a `tolerance`'s band, a bounded distribution's support, or ±3σ): the centre and
    /// every corner (all of them up to 12 inputs), then a compass search from the best
    /// ones, since a mechanism's extreme need not be at a corner. Runs go in parallel into
    /// <results>/worst-case/ (resumable). Prints the extremes and the inputs that reach
    /// them, and beside the study's results: the linear worst case, the RSS prediction
    /// (mean ± 3σ, with R²), the Monte-Carlo range, which break the limits, and each
    /// input's share of the variance (docs/tolerancing.md).
    WorstCase(WorstCaseArgs),
    /// Tolerance allocation: the tolerance widths of least total cost (each parameter's
    /// `cost`, default 1/t) under which every output with limits reaches the study's
    /// `allocation` target (Cpk, or ppm through the normal model). Starts from the study's
    /// results (running it first if needed), reweights them to try tolerances without new
    /// runs, confirms each allocation with a study in <results>/allocation/round-N, and
    /// writes the allocated study beside the study file (STUDY.allocated.yaml). Exit
    /// status 3 when the target cannot be met.
    Allocate(AllocateArgs),
    /// Lists every parameter path of a scene (the numbers a study or `--set` can vary),
    /// with its unit and its value in the scene ("default" where the scene leaves it out).
    Paths {
        /// Scene YAML file.
        scene: PathBuf,
    },
    /// Runs one simulation of a scene and prints its diagnostics (steps, penetration,
    /// solver and Newton failures, work and wall time per step) and its probes; on request
    /// writes the trajectory and draws the mechanism.
    Simulate {
        /// Scene YAML file (see studies/*/scene.yaml).
        scene: PathBuf,
        /// Trajectory output: .csv or .parquet (t, energy, each body's pose and twist, each
        /// contact's gap and impulse). Nothing is written without it.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Override the scene's duration, in seconds.
        #[arg(long)]
        duration: Option<f64>,
        /// Set a scene parameter before the run, as a study would: PATH=VALUE, the value in
        /// SI or with a unit, e.g. `--set joints.J3.clearance=0.1mm`. Repeatable.
        #[arg(long = "set", value_name = "PATH=VALUE")]
        set: Vec<String>,
        /// Draw the mechanism at the `--snapshots` times, side by side, into this SVG file
        /// (bodies as their inertia boxes, contact shapes, bores and journals; mm).
        #[arg(long)]
        svg: Option<PathBuf>,
        /// Times of the drawn configurations, comma-separated, e.g. `2ms,8ms` (default:
        /// the start and the end of the run).
        #[arg(long, value_delimiter = ',')]
        snapshots: Vec<String>,
        /// Projection plane of the drawing: xy (default), xz or yz.
        #[arg(long, default_value = "xy")]
        view: String,
    },
}

fn main() -> std::process::ExitCode {
    // `mc-study paths SCENE | head` ends quietly when the reader goes, as a Unix tool does,
    // instead of panicking on the broken pipe
    // SAFETY: restoring a signal's default disposition before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Run {
            study,
            samples,
            out,
            threads,
            shard,
            shards,
            quiet,
            part_rows,
            part_seconds,
        } => {
            let shard = match (shard, shards) {
                (Some(s), _) => Shard::parse(s).map(Some),
                (None, Some(n)) => Shard::parse(&format!("/{n}")).map(Some),
                (None, None) => Ok(None),
            };
            match shard {
                Err(e) => Err(e.into()),
                Ok(shard) => match run(
                    study,
                    RunArgs {
                        samples: *samples,
                        out: out.clone(),
                        threads: *threads,
                        shard,
                        quiet: *quiet,
                        part_rows: *part_rows,
                        part_seconds: *part_seconds,
                    },
                ) {
                    Ok(None) => Ok(()),
                    Ok(Some(status)) => return std::process::ExitCode::from(status),
                    Err(e) => Err(e),
                },
            }
        }
        Command::WorstCase(args) => match worst_case(args) {
            Ok(None) => Ok(()),
            Ok(Some(status)) => return std::process::ExitCode::from(status),
            Err(e) => Err(e),
        },
        Command::Allocate(args) => match allocate(args) {
            Ok(None) => Ok(()),
            Ok(Some(status)) => return std::process::ExitCode::from(status),
            Err(e) => Err(e),
        },
        Command::Merge { out, .. } if mc_study::reliability::study::is_rare_event_dir(out) => {
            mc_study::reliability::study::merge(out).map(|(f, study)| {
                print!("{}", mc_study::reliability::study::describe(&f, &study));
                eprintln!("results: {}", f.results.display());
            })
        }
        Command::Status { out, .. } if mc_study::reliability::study::is_rare_event_dir(out) => {
            mc_study::reliability::study::status(out).map(|s| print!("{s}"))
        }
        Command::Merge { out, allow_partial } => merge(out, *allow_partial).map(|m| {
            print!("{}", m.summary);
            eprintln!("results: {} ({} rows)", m.path.display(), m.rows);
            if !m.missing.is_empty() {
                eprintln!(
                    "partial: {} samples missing ({})",
                    m.missing.count(),
                    m.missing.describe(8)
                );
            }
        }),
        Command::Paths { scene } => Scene::load(scene).map_err(Into::into).map(|s| {
            for p in s.parameters() {
                let value = p.value.map_or("default".into(), |v| format!("{v}"));
                println!("{:<48} {:<8} {value}", p.path, p.dim.si_unit());
            }
        }),
        Command::Status { out, shards } => status(out, *shards).map(|s| print!("{s}")),
        Command::Report { out } => mc_study::report::build(out).map(|r| {
            println!(
                "report: {} ({} figures, each also as .svg and .png in {})",
                r.html.display(),
                r.figures.len(),
                r.html.with_file_name("figures").display()
            );
        }),
        Command::Converge {
            study,
            out,
            samples,
            results,
            target,
            h,
            threads,
        } => converge(ConvergeArgs {
            study,
            out: out.as_ref(),
            samples: *samples,
            results: results.as_ref(),
            target: *target,
            hs: h,
            threads: *threads,
        }),
        Command::Slurm {
            study,
            tasks,
            out,
            samples,
            partition,
            time,
            cpus_per_task,
            mem,
            account,
            part_rows,
            submit,
        } => slurm(
            study,
            out.as_ref(),
            SlurmOptions {
                tasks: *tasks,
                partition: partition.clone(),
                time: time.clone(),
                cpus_per_task: *cpus_per_task,
                mem: mem.clone(),
                account: account.clone(),
                samples: *samples,
                part_rows: *part_rows,
            },
            *submit,
        ),
        Command::Simulate {
            scene,
            out,
            duration,
            set,
            svg,
            snapshots,
            view,
        } => simulate_command(SimulateArgs {
            scene,
            out: out.as_ref(),
            duration: *duration,
            sets: set,
            svg: svg.as_ref(),
            snapshots,
            view,
        }),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::from(2)
        }
    }
}
