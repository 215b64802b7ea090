//! `mc-study slurm`: writes (and submits) the Slurm job array of a study.

use crate::study::manifest::Manifest;
use crate::study::slurm::{sbatch, write_scripts, SlurmOptions};
use crate::study::Study;
use anyhow::{bail, Context, Result};
use std::path::PathBuf;

/// `mc-study slurm` arguments.
#[derive(clap::Args, Debug)]
pub struct SlurmArgs {
    /// Study YAML file.
    pub study: PathBuf,
    /// Number of array tasks N (shards).
    #[arg(long)]
    pub tasks: u64,
    /// Output directory shared by all tasks (default: the study's `output`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Number of samples (overrides the study's `samples`).
    #[arg(long)]
    pub samples: Option<u64>,
    /// Slurm partition.
    #[arg(long)]
    pub partition: Option<String>,
    /// Time limit per task (Slurm format, e.g. 02:00:00).
    #[arg(long)]
    pub time: Option<String>,
    /// CPUs per task; each task runs that many worker threads (default 1).
    #[arg(long)]
    pub cpus_per_task: Option<u32>,
    /// Memory per task (Slurm format, e.g. 2G).
    #[arg(long)]
    pub mem: Option<String>,
    /// Slurm account to charge.
    #[arg(long)]
    pub account: Option<String>,
    /// Samples per part file written by the tasks (default 1024; smaller loses less
    /// when a task is killed or preempted).
    #[arg(long)]
    pub part_rows: Option<usize>,
    /// Submit the array and the merge job with sbatch and print their ids.
    #[arg(long)]
    pub submit: bool,
}

/// `mc-study slurm`: writes the array and merge scripts and, with `--submit`, submits
/// them.
pub fn slurm(args: &SlurmArgs) -> Result<()> {
    let mut o = SlurmOptions {
        tasks: args.tasks,
        partition: args.partition.clone(),
        time: args.time.clone(),
        cpus_per_task: args.cpus_per_task,
        mem: args.mem.clone(),
        account: args.account.clone(),
        samples: args.samples,
        part_rows: args.part_rows,
    };
    let (study_path, submit) = (&args.study, args.submit);
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
    let out = std::path::absolute(args.out.as_ref().unwrap_or(&study.output_dir))?;
    crate::study::runner::check_out(&out)?;
    if crate::study::manifest::path(&out).exists() {
        Manifest::load(&out)?.check_same_study(&study.hash(), &out)?;
    }
    let exe = std::env::current_exe().context("locating the mc-study executable")?;
    let study_abs = std::fs::canonicalize(study_path)?;
    o.cpus_per_task = Some(o.cpus_per_task.unwrap_or(1));
    let (array, merge_script) =
        crate::study::slurm::scripts(&study.name, &exe, &study_abs, &out, &o);
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
