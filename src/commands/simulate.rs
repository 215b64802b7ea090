//! `mc-study simulate`: loads a scene, applies `--set`, runs it and prints its report.

use crate::input::units::{parse_quantity, Dim};
use crate::scene::Scene;
use crate::single_run::{simulate, DrawingRequest, SimulateOptions};
use anyhow::{bail, Result};
use std::path::PathBuf;

/// `mc-study simulate` arguments.
#[derive(clap::Args, Debug)]
pub struct SimulateArgs {
    /// Scene YAML file (see studies/*/scene.yaml).
    pub scene: PathBuf,
    /// Trajectory output: .csv or .parquet (t, energy, each body's pose and twist, each
    /// contact's gap and impulse, each joint's reaction, each drive's effort, each value
    /// probe's measure), every `record.every` steps. Nothing is written without it.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Override the scene's duration, in seconds.
    #[arg(long)]
    pub duration: Option<f64>,
    /// Set a scene parameter before the run, as a study would: PATH=VALUE, the value in
    /// SI or with a unit, e.g. `--set joints.J3.clearance=0.1mm`. Repeatable.
    #[arg(long = "set", value_name = "PATH=VALUE")]
    pub sets: Vec<String>,
    /// Draw the mechanism at the `--snapshots` times, side by side, into this SVG file
    /// (bodies as their inertia boxes, contact shapes, bores and journals; mm).
    #[arg(long)]
    pub svg: Option<PathBuf>,
    /// Times of the drawn configurations, comma-separated, e.g. `2ms,8ms` (default:
    /// the start and the end of the run).
    #[arg(long, value_delimiter = ',')]
    pub snapshots: Vec<String>,
    /// Projection plane of the drawing: xy (default), xz or yz.
    #[arg(long, default_value = "xy")]
    pub view: String,
}

/// `mc-study simulate`: one run of a scene, its report, and the files asked for.
pub fn simulate_command(args: &SimulateArgs) -> Result<()> {
    let mut scene = Scene::load(&args.scene)?;
    for s in &args.sets {
        check_unit(&scene, s)?;
        scene
            .apply_setting(s)
            .map_err(|e| anyhow::anyhow!("--set {e}"))?;
    }
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(p) = &args.out {
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
    let drawing = match &args.svg {
        Some(svg) => Some(
            DrawingRequest::parse(svg.clone(), &args.snapshots, &args.view, duration)
                .map_err(anyhow::Error::msg)?,
        ),
        None if !args.snapshots.is_empty() => bail!("--snapshots needs --svg FILE"),
        None => None,
    };
    let options = SimulateOptions {
        duration: Some(duration),
        trajectory: args.out.clone(),
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

/// On the command line a dimensional value needs its unit: `joints.B.clearance=0.1` would
/// be 100 mm in SI, which nobody types on purpose. Zero is zero in every unit. (Files keep
/// their rule, bare numbers in SI, and so does the Python API.)
fn check_unit(scene: &Scene, setting: &str) -> Result<()> {
    let Some((path, value)) = setting.split_once('=') else {
        return Ok(());
    };
    let (path, value) = (path.trim(), value.trim());
    let (Ok(dim), Ok(q)) = (scene.parameter_dim(path), parse_quantity(value)) else {
        // apply_setting names what is wrong
        return Ok(());
    };
    if q.dim.is_none() && dim != Dim::NONE && q.si != 0.0 {
        bail!(
            "--set `{setting}`: `{path}` is {}: write its unit, e.g. `{path}={value} {}`",
            dim.describe(),
            dim.si_unit()
        );
    }
    Ok(())
}
