//! The commands of the `mc-study` executable: each takes its parsed arguments, does the
//! work through the library and prints what the user reads. `main.rs` holds only the
//! argument definitions and the dispatch.

mod allocate;
mod converge;
mod run;
mod simulate;
mod slurm;
mod worst_case;

pub use allocate::{allocate, AllocateArgs};
pub use converge::{converge, ConvergeArgs};
pub use run::{run, RunArgs};
pub use simulate::{simulate_command, SimulateArgs};
pub use slurm::slurm;
pub use worst_case::{worst_case, WorstCaseArgs};

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
