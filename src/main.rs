//! The `mc-study` command line: clap parses, `mc_study::commands` does the work.

use clap::Parser;
use mc_study::commands::Command;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "mc-study",
    version,
    about = "Monte-Carlo tolerance studies of mechanisms with clearances on an exact nonsmooth (Moreau–Jean) integrator",
    after_help = "Paths written in a study or scene file are relative to that file; paths given on the command line are relative to the working directory.\nGuides: README.md and docs/ in the source tree. `mc-study <command> --help` explains a command."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

fn main() -> ExitCode {
    // `mc-study paths SCENE | head` ends quietly when the reader goes, as a Unix tool does,
    // instead of panicking on the broken pipe
    // SAFETY: restoring a signal's default disposition before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    match Cli::parse().command.execute() {
        Ok(None) => ExitCode::SUCCESS,
        Ok(Some(status)) => ExitCode::from(status),
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}
