//! The `mc-study` command line: the commands and their options (clap), each dispatched to
//! the library, which does the work and formats what is printed.

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use mc_study::scene::Scene;
use mc_study::simulate::{simulate, DrawingRequest, SimulateOptions};
use mc_study::study::converge::{sigma_of, sweep, Fidelity, Ladder};
use mc_study::study::manifest::Manifest;
use mc_study::study::merge::{merge, status};
use mc_study::study::runner::{self, RunOptions, Shard};
use mc_study::study::slurm::{sbatch, write_scripts, SlurmOptions};
use mc_study::study::stop_signals::StopSignals;
use mc_study::study::subject::Subject;
use mc_study::study::summary::Summary;
use mc_study::study::Study;
use std::path::{Path, PathBuf};

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
    /// with exit status 128 + the signal's number; a second signal exits at once.
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

struct SimulateArgs<'a> {
    scene: &'a Path,
    out: Option<&'a PathBuf>,
    duration: Option<f64>,
    sets: &'a [String],
    svg: Option<&'a PathBuf>,
    snapshots: &'a [String],
    view: &'a str,
}

fn run_simulate(args: SimulateArgs) -> Result<()> {
    let mut scene = Scene::load(args.scene)?;
    for s in args.sets {
        scene
            .apply_setting(s)
            .map_err(|e| anyhow::anyhow!("--set {e}"))?;
    }
    if let Some(p) = args.out {
        let ext = p.extension().and_then(|e| e.to_str());
        if !matches!(ext, Some("csv" | "parquet")) {
            bail!("--out must end in .csv or .parquet");
        }
    }
    let duration = match args.duration {
        Some(d) if !(d > 0.0 && d.is_finite()) => {
            bail!("--duration must be a positive number of seconds, got {d}")
        }
        Some(d) => d,
        None => scene.duration,
    };
    let drawing = match args.svg {
        Some(svg) => Some(
            DrawingRequest::parse(svg.clone(), args.snapshots, args.view, duration)
                .map_err(anyhow::Error::msg)?,
        ),
        None if !args.snapshots.is_empty() => bail!("--snapshots needs --svg FILE"),
        None => None,
    };
    let options = SimulateOptions {
        duration: Some(duration),
        trajectory: args.out.cloned(),
        drawing,
    };
    let report = simulate(&scene, &args.scene.display().to_string(), &options)?;
    print!("{report}");
    if let Some(e) = &report.error {
        bail!("{e}");
    }
    if report.nonconverged_steps() > 0 {
        eprintln!(
            "warning: {} step(s) did not converge; see the counts above",
            report.nonconverged_steps()
        );
    }
    Ok(())
}

struct ConvergeArgs<'a> {
    study: &'a Path,
    out: Option<&'a PathBuf>,
    samples: u64,
    results: Option<&'a PathBuf>,
    target: Option<f64>,
    hs: &'a [f64],
    threads: Option<usize>,
}

fn converge(args: ConvergeArgs) -> Result<()> {
    let study = Study::load(args.study, None)?;
    let Subject::Mechanism(scene) = &study.subject else {
        bail!("converge needs a mechanism scene: a function scene has no fidelity to vary");
    };
    let base = Fidelity::of(&scene.params);
    let mut ladder = Ladder::around_scene(scene, args.samples);
    if !args.hs.is_empty() {
        if let Some(h) = args.hs.iter().find(|h| !(**h > 0.0 && h.is_finite())) {
            bail!("--h: step sizes must be positive, got {h}");
        }
        ladder.fidelities = args
            .hs
            .iter()
            .map(|&h| Fidelity { h, ..base.clone() })
            .collect();
        let finest = args.hs.iter().copied().fold(f64::INFINITY, f64::min);
        ladder.reference.h = ladder.reference.h.min(finest / 2.0);
    }
    let results_dir = args
        .results
        .cloned()
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
    print!("{conv}");
    let dir = args
        .out
        .cloned()
        .unwrap_or_else(|| study.output_dir.join("converge"));
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let csv = dir.join("converge.csv");
    std::fs::write(&csv, conv.csv()).with_context(|| format!("writing {}", csv.display()))?;
    let plot = mc_study::report::figures::save(
        &mc_study::report::work_precision(&conv, target),
        &dir.join("work-precision"),
    )?;
    eprintln!(
        "runs: {}; work–precision plot: {} (and .png)",
        csv.display(),
        plot.display()
    );
    match conv.recommend(target) {
        Some(f) => {
            println!(
                "cheapest fidelity with every error below {target}{}: {:.1} ms per sample",
                if conv.sigma.is_some() { " σ" } else { "" },
                conv.cost(f)
            );
            print!("{}", conv.fidelities[f].yaml());
        }
        None if conv.step_dependent().len() == conv.outputs.len() => println!(
            "every output depends on the step size (see above): no fidelity can be recommended"
        ),
        None => println!(
            "no fidelity of the ladder meets the target {target} on the outputs that converge; refine h"
        ),
    }
    Ok(())
}

/// A rayon pool of `threads` workers (default: all cores).
fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    check_threads(threads)?;
    let mut b = rayon::ThreadPoolBuilder::new();
    if let Some(t) = threads {
        b = b.num_threads(t);
    }
    b.build().context("starting the worker threads")
}

/// More worker threads than this is a typo, not a machine.
const MAX_THREADS: usize = 4096;

fn check_threads(threads: Option<usize>) -> Result<()> {
    match threads {
        Some(t) if t == 0 || t > MAX_THREADS => {
            bail!("--threads {t}: give a number from 1 to {MAX_THREADS} (default: all cores)")
        }
        _ => Ok(()),
    }
}

/// `mc-study run` arguments.
struct RunArgs {
    samples: Option<u64>,
    out: Option<PathBuf>,
    threads: Option<usize>,
    shard: Option<Shard>,
    quiet: bool,
    part_rows: usize,
    part_seconds: f64,
}

/// Runs a study; `Ok(Some(status))` when a stop signal came (the samples done are saved).
fn run(study: &Path, args: RunArgs) -> Result<Option<u8>> {
    let study = Study::load(study, args.samples)?;
    check_threads(args.threads)?;
    if args.part_rows == 0 || args.part_seconds.is_nan() || args.part_seconds <= 0.0 {
        bail!("--part-rows and --part-seconds must be positive");
    }
    let out = args.out.unwrap_or_else(|| study.output_dir.clone());
    let mut opts = RunOptions::new(out.clone());
    opts.threads = args.threads;
    opts.shard = args.shard.unwrap_or(Shard::WHOLE);
    opts.progress = !args.quiet;
    opts.rows_per_part = args.part_rows;
    opts.seconds_per_part = args.part_seconds;
    let signals = StopSignals::listen(opts.stop.clone())?;
    for o in &study.outputs {
        if let Some(c) = &o.caution {
            eprintln!("caution: {c}");
        }
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

fn slurm(
    study_path: &Path,
    out: Option<&PathBuf>,
    mut o: SlurmOptions,
    submit: bool,
) -> Result<()> {
    let study = Study::load(study_path, o.samples)?;
    if o.tasks == 0 || o.tasks > study.runs() {
        bail!(
            "--tasks must be between 1 and the study's {} runs, got {}",
            study.runs(),
            o.tasks
        );
    }
    if o.part_rows == Some(0) {
        bail!("--part-rows must be ≥ 1");
    }
    let out = std::path::absolute(out.unwrap_or(&study.output_dir))?;
    if mc_study::study::manifest::path(&out).exists() {
        Manifest::load(&out)?.check_same_study(&study.hash(), &out)?;
    }
    let exe = std::env::current_exe().context("locating the mc-study executable")?;
    let study_abs = std::fs::canonicalize(study_path)?;
    o.cpus_per_task = Some(o.cpus_per_task.unwrap_or(1));
    let (array, merge_script) =
        mc_study::study::slurm::scripts(&study.name, &exe, &study_abs, &out, &o);
    let (a, m) = write_scripts(&out, &array, &merge_script)?;
    let per = study.runs().div_ceil(o.tasks);
    println!(
        "wrote {} ({} tasks, about {per} of the {} samples each, {} CPU(s) per task) and {}",
        a.display(),
        o.tasks,
        study.runs(),
        o.cpus_per_task.unwrap_or(1),
        m.display()
    );
    let (a, m, d) = (a.display(), m.display(), out.display());
    if submit {
        let job = sbatch(&[&a.to_string()])?;
        let merge_job = sbatch(&[&format!("--dependency=afterany:{job}"), &m.to_string()])?;
        println!("submitted array job {job} (tasks {job}_0 … {job}_{}) and merge job {merge_job} (runs after every task ended)", o.tasks - 1);
        println!("watch:     squeue -j {job}    or    mc-study status {d}");
    } else {
        println!(
            "submit:    job=$(sbatch --parsable {a}) && sbatch --dependency=afterany:$job {m}"
        );
        println!("watch:     squeue -j <job>    or    mc-study status {d}");
    }
    println!("resubmit:  sbatch --array=<indices from `mc-study status {d}`> {a}   (a task resumes its shard)");
    println!("merge:     sbatch --dependency=afterany:<job> {m}    or    mc-study merge {d}");
    println!("logs:      {d}/slurm/logs/");
    Ok(())
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
        } => run_simulate(SimulateArgs {
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
