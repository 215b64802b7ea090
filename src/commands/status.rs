//! `mc-study status`: which shards of a result directory are done, running, partial or
//! missing.

use crate::reliability::study as rare_event;
use anyhow::Result;
use std::path::PathBuf;

/// `mc-study status` arguments.
#[derive(clap::Args, Debug)]
pub struct StatusArgs {
    /// Result directory of a study.
    pub out: PathBuf,
    /// Shard count to report on (default: that of the latest run).
    #[arg(long)]
    pub shards: Option<u64>,
}

/// `mc-study status`: the shards' table (a rare-event study's batches, for its
/// directories).
pub fn status(args: &StatusArgs) -> Result<()> {
    let text = match rare_event::is_rare_event_dir(&args.out) {
        true => rare_event::status(&args.out)?,
        false => crate::study::merge::status(&args.out, args.shards)?.to_string(),
    };
    print!("{text}");
    Ok(())
}
