//! The signals that stop a run: SIGINT (Ctrl-C), SIGTERM (what Slurm sends at a time
//! limit, at preemption and on `scancel`) and SIGHUP (a closed terminal). The first one
//! asks the runner to stop starting samples; the samples under way finish and every
//! finished one is written before the process exits with 128 + the signal's number. A
//! second signal exits at once: what is already in part files is kept, the rest is lost.

use anyhow::{Context, Result};
use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
use signal_hook::iterator::Signals;
use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};
use std::sync::Arc;

/// Which stop signal arrived first, if any.
#[derive(Clone)]
pub struct StopSignals {
    first: Arc<AtomicI32>,
}

fn name(signal: i32) -> &'static str {
    match signal {
        SIGINT => "interrupt (SIGINT)",
        SIGTERM => "termination request (SIGTERM)",
        SIGHUP => "hang-up (SIGHUP)",
        _ => "signal",
    }
}

impl StopSignals {
    /// Listens for SIGINT, SIGTERM and SIGHUP on a thread of its own; the first sets `stop`.
    pub fn listen(stop: Arc<AtomicBool>) -> Result<StopSignals> {
        let mut signals =
            Signals::new([SIGINT, SIGTERM, SIGHUP]).context("installing the signal handlers")?;
        let first = Arc::new(AtomicI32::new(0));
        let seen = first.clone();
        std::thread::Builder::new()
            .name("stop-signals".into())
            .spawn(move || {
                for signal in signals.forever() {
                    if seen
                        .compare_exchange(0, signal, Ordering::SeqCst, Ordering::SeqCst)
                        .is_err()
                    {
                        eprintln!(
                            "\nsecond stop signal ({}): exiting now; rerun the same command to resume",
                            name(signal)
                        );
                        std::process::exit(128 + signal);
                    }
                    stop.store(true, Ordering::SeqCst);
                    eprintln!(
                        "\n{}: finishing the samples under way and writing them (a second signal quits at once)",
                        name(signal)
                    );
                }
            })
            .context("starting the signal thread")?;
        Ok(StopSignals { first })
    }

    /// The exit status owed to the first stop signal (128 + its number), if one came.
    pub fn exit_status(&self) -> Option<u8> {
        match self.first.load(Ordering::SeqCst) {
            0 => None,
            s => u8::try_from(128 + s).ok(),
        }
    }
}
