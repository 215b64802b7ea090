//! `mc-study compare`: two runs of one study, sample by sample.

use crate::study::compare::compare as compare_tables;
use crate::study::store;
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};

/// `mc-study compare` arguments.
#[derive(clap::Args, Debug)]
pub struct CompareArgs {
    /// The reference: a result directory (its results.parquet) or a results file, e.g. the
    /// study run once at a finer fidelity.
    pub reference: PathBuf,
    /// The run to judge: a result directory or a results file of the same study.
    pub other: PathBuf,
    /// Difference, in units of the reference's σ, above which a sample counts as off.
    #[arg(long, default_value_t = 0.01)]
    pub target: f64,
    /// Write every compared sample's differences (in units of σ) to this CSV file.
    #[arg(long)]
    pub csv: Option<PathBuf>,
    /// Exit with status 1 when some sample is above the target.
    #[arg(long)]
    pub check: bool,
}

/// The results file of a result directory, or the file itself.
fn results_file(path: &Path) -> Result<PathBuf> {
    if path.is_dir() {
        let file = path.join("results.parquet");
        if !file.is_file() {
            bail!(
                "{}: no results.parquet (run `mc-study merge {}` first)",
                path.display(),
                path.display()
            );
        }
        return Ok(file);
    }
    if !path.is_file() {
        bail!("{}: no such result directory or file", path.display());
    }
    Ok(path.to_path_buf())
}

/// `mc-study compare`: the table of differences; `Some(1)` with `--check` when a sample is
/// above the target.
pub fn compare(args: &CompareArgs) -> Result<Option<u8>> {
    if !(args.target.is_finite() && args.target > 0.0) {
        bail!(
            "--target {}: give a positive fraction of σ, e.g. 0.01",
            args.target
        );
    }
    let read = |p: &Path| -> Result<store::Table> {
        let file = results_file(p)?;
        store::read(&file).with_context(|| format!("reading {}", file.display()))
    };
    let (reference, other) = (read(&args.reference)?, read(&args.other)?);
    let c = compare_tables(&reference, &other, args.target);
    if c.outputs.is_empty() {
        bail!(
            "{} and {} share no output: are they runs of the same study?",
            args.reference.display(),
            args.other.display()
        );
    }
    print!("{c}");
    if let Some(path) = &args.csv {
        std::fs::write(path, c.csv()).with_context(|| format!("writing {}", path.display()))?;
        eprintln!("per-sample differences: {}", path.display());
    }
    Ok((args.check && !c.within_target()).then_some(1))
}
