//! Slurm job arrays for a study: `OUT/slurm/array.sbatch` (task i runs shard i/N of the
//! study into the shared OUT; a resubmitted task resumes its shard) and
//! `OUT/slurm/merge.sbatch` (submitted with `--dependency=afterany:<array job>`). We write
//! scripts and call `sbatch`; the scheduler is Slurm's.

use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};
use std::process::Command;

/// What the array tasks ask of the scheduler.
#[derive(Clone, Debug, Default)]
pub struct SlurmOptions {
    pub tasks: u64,
    pub partition: Option<String>,
    pub time: Option<String>,
    pub cpus_per_task: Option<u32>,
    pub mem: Option<String>,
    pub account: Option<String>,
    /// Overrides the study's `samples`, passed on to every task.
    pub samples: Option<u64>,
    /// `--part-rows` of the tasks (samples per part file).
    pub part_rows: Option<usize>,
}

/// Quotes a word for bash (single quotes; embedded quotes escaped).
fn quote(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "/._-+=:,@%".contains(c))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

fn directive(lines: &mut Vec<String>, key: &str, value: &Option<String>) {
    if let Some(v) = value {
        lines.push(format!("#SBATCH --{key}={v}"));
    }
}

/// The two scripts: (array.sbatch, merge.sbatch). Paths must be absolute: tasks run on
/// other machines, from other directories.
pub fn scripts(
    name: &str,
    exe: &Path,
    study: &Path,
    out: &Path,
    o: &SlurmOptions,
) -> (String, String) {
    let logs = out.join("slurm").join("logs");
    let job = format!(
        "mc-{}",
        name.replace(|c: char| !c.is_ascii_alphanumeric() && c != '-', "_")
    );
    let mut a = vec![
        "#!/bin/bash".to_string(),
        format!(
            "# mc-study: {} tasks of study `{name}`; task i runs shard i/{}.",
            o.tasks, o.tasks
        ),
        "# Resubmit only some tasks with: sbatch --array=3,5 THIS_FILE (a task resumes its shard)."
            .to_string(),
        format!("#SBATCH --job-name={job}"),
        format!("#SBATCH --array=0-{}", o.tasks - 1),
        format!("#SBATCH --output={}/task-%a.out", logs.display()),
        "#SBATCH --open-mode=append".to_string(),
        format!("#SBATCH --cpus-per-task={}", o.cpus_per_task.unwrap_or(1)),
        // SIGTERM a minute before the time limit: the task writes its finished samples
        // and exits; a resubmitted task resumes the shard
        "#SBATCH --signal=B:TERM@60".to_string(),
    ];
    directive(&mut a, "partition", &o.partition);
    directive(&mut a, "time", &o.time);
    directive(&mut a, "mem", &o.mem);
    directive(&mut a, "account", &o.account);
    let mut run = vec![
        quote(&exe.display().to_string()),
        "run".into(),
        quote(&study.display().to_string()),
        "--out".into(),
        quote(&out.display().to_string()),
        // N is written here, not read from SLURM_ARRAY_TASK_COUNT, which a resubmission
        // of some indices changes
        format!("--shard \"$SLURM_ARRAY_TASK_ID/{}\"", o.tasks),
        "--threads \"${SLURM_CPUS_PER_TASK:-1}\"".into(),
    ];
    if let Some(n) = o.samples {
        run.push(format!("--samples {n}"));
    }
    if let Some(r) = o.part_rows {
        run.push(format!("--part-rows {r}"));
    }
    a.push("set -euo pipefail".into());
    a.push(format!("exec {}", run.join(" ")));
    let mut m = vec![
        "#!/bin/bash".to_string(),
        format!("# mc-study: merge the shards of study `{name}` (submit with --dependency=afterany:<array job>)."),
        format!("#SBATCH --job-name={job}-merge"),
        format!("#SBATCH --output={}/merge-%j.out", logs.display()),
        "#SBATCH --cpus-per-task=1".to_string(),
    ];
    directive(&mut m, "partition", &o.partition);
    directive(&mut m, "time", &o.time);
    directive(&mut m, "account", &o.account);
    m.push("set -euo pipefail".into());
    m.push(format!(
        "exec {} merge {}",
        quote(&exe.display().to_string()),
        quote(&out.display().to_string())
    ));
    (a.join("\n") + "\n", m.join("\n") + "\n")
}

/// Writes the scripts into `OUT/slurm/` (and creates `OUT/slurm/logs/`); returns their paths.
pub fn write_scripts(out: &Path, array: &str, merge: &str) -> Result<(PathBuf, PathBuf)> {
    let dir = out.join("slurm");
    std::fs::create_dir_all(dir.join("logs"))
        .with_context(|| format!("creating {}", dir.display()))?;
    let a = dir.join("array.sbatch");
    let m = dir.join("merge.sbatch");
    std::fs::write(&a, array)?;
    std::fs::write(&m, merge)?;
    Ok((a, m))
}

/// `sbatch --parsable ARGS…`: the job id.
pub fn sbatch(args: &[&str]) -> Result<String> {
    let out = Command::new("sbatch")
        .arg("--parsable")
        .args(args)
        .output()
        .context("running sbatch (is Slurm installed and SLURM_CONF set?)")?;
    if !out.status.success() {
        bail!(
            "sbatch {} failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let text = String::from_utf8_lossy(&out.stdout);
    // --parsable prints "jobid" or "jobid;cluster"
    let id = text.trim().split(';').next().unwrap_or("").to_string();
    if id.is_empty() || !id.chars().all(|c| c.is_ascii_digit()) {
        bail!("sbatch printed `{}`, not a job id", text.trim());
    }
    Ok(id)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn array_script_runs_shard_i_of_n_with_the_allocated_cpus() {
        let o = SlurmOptions {
            tasks: 8,
            partition: Some("batch".into()),
            time: Some("01:00:00".into()),
            samples: Some(30850),
            ..Default::default()
        };
        let (a, m) = scripts(
            "c60 full",
            Path::new("/opt/mc-study"),
            Path::new("/data/my study.yaml"),
            Path::new("/scratch/out"),
            &o,
        );
        assert!(a.contains("#SBATCH --array=0-7\n"));
        assert!(a.contains("#SBATCH --partition=batch\n#SBATCH --time=01:00:00\n"));
        assert!(a.contains(
            "exec /opt/mc-study run '/data/my study.yaml' --out /scratch/out --shard \"$SLURM_ARRAY_TASK_ID/8\" --threads \"${SLURM_CPUS_PER_TASK:-1}\" --samples 30850\n"
        ));
        assert!(a.contains("#SBATCH --output=/scratch/out/slurm/logs/task-%a.out"));
        assert!(a.contains("#SBATCH --job-name=mc-c60_full\n"));
        assert!(m.contains("exec /opt/mc-study merge /scratch/out\n"));
        assert!(!a.contains("--mem") && !a.contains("--account"));
        assert_eq!(quote("it's"), r"'it'\''s'");
    }
}
