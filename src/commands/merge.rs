//! `mc-study merge`: gathers a result directory's part files into results.parquet and
//! prints the summary (a rare-event study's estimate, for its directories).

use crate::reliability::study as rare_event;
use anyhow::Result;
use std::path::PathBuf;

/// `mc-study merge` arguments.
#[derive(clap::Args, Debug)]
pub struct MergeArgs {
    /// Result directory of a study (the `--out` of `run`).
    pub out: PathBuf,
    /// Merge even if samples are missing (the summary then covers those present).
    #[arg(long)]
    pub allow_partial: bool,
}

/// `mc-study merge`: the merged results and their summary.
pub fn merge(args: &MergeArgs) -> Result<()> {
    if rare_event::is_rare_event_dir(&args.out) {
        let (f, study) = rare_event::merge(&args.out)?;
        print!("{}", rare_event::describe(&f, &study));
        eprintln!("results: {}", f.results.display());
        return Ok(());
    }
    let m = crate::study::merge::merge(&args.out, args.allow_partial)?;
    print!("{}", m.summary);
    eprintln!("results: {} ({} rows)", m.path.display(), m.rows);
    if !m.missing.is_empty() {
        eprintln!(
            "partial: {} samples missing ({})",
            m.missing.count(),
            m.missing.describe(8)
        );
    }
    Ok(())
}
