//! `mc-study report`: the self-contained HTML report of a result directory.

use anyhow::Result;
use std::path::PathBuf;

/// `mc-study report` arguments.
#[derive(clap::Args, Debug)]
pub struct ReportArgs {
    /// Result directory of a study (merged or not).
    pub out: PathBuf,
}

/// `mc-study report`: writes the page and its figures and says where.
pub fn report(args: &ReportArgs) -> Result<()> {
    let r = crate::report::build(&args.out)?;
    println!(
        "report: {} ({} figures, each also as .svg and .png in {})",
        r.html.display(),
        r.figures.len(),
        r.html.with_file_name("figures").display()
    );
    for c in &r.curves {
        if let Some(line) = crate::report::curves::describe(c) {
            println!("{line}");
        }
    }
    Ok(())
}
