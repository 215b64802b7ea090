//! The `mc-study` command line: subcommands only, no logic.

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use mc_study::integrator::Simulation;
use mc_study::scene::Scene;
use mc_study::trajectory::Trajectory;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Parser)]
#[command(
    name = "mc-study",
    version,
    about = "Monte-Carlo tolerance studies of mechanisms with clearances on an exact nonsmooth (Moreau–Jean) integrator"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Runs one simulation of a scene: writes the trajectory and prints diagnostics
    /// (steps, max penetration, solver failures, wall time).
    Simulate {
        /// Scene YAML file (see studies/*/scene.yaml).
        scene: PathBuf,
        /// Trajectory output: .csv or .parquet (t, energy, each body's pose and twist, each
        /// contact's gap and impulse). Nothing is written without it.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Override the scene's duration, in seconds.
        #[arg(long)]
        duration: Option<f64>,
    },
}

fn simulate(scene_path: &Path, out: Option<&PathBuf>, duration: Option<f64>) -> Result<()> {
    let scene = Scene::load(scene_path)?;
    let format = match out.and_then(|p| p.extension()).and_then(|e| e.to_str()) {
        None if out.is_none() => None,
        Some("csv") => Some("csv"),
        Some("parquet") => Some("parquet"),
        _ => bail!("--out must end in .csv or .parquet"),
    };
    let duration = match duration {
        Some(d) if !(d > 0.0 && d.is_finite()) => {
            bail!("--duration must be a positive number of seconds, got {d}")
        }
        Some(d) => d,
        None => scene.duration,
    };
    let every = scene.record_every;
    let mut sim = Simulation::new(scene.model, scene.params)?;
    let mut traj = Trajectory::for_simulation(&sim);
    traj.record(&sim);
    let start = Instant::now();
    let result = sim.run_until(duration, |s, _| {
        if format.is_some() && s.stats.steps % every as u64 == 0 {
            traj.record(s);
        }
    });
    let wall = start.elapsed();
    let st = sim.stats;
    println!("scene            {} ({})", scene.name, scene_path.display());
    println!(
        "scheme           {} h = {:e} s, θ = {}",
        sim.params.scheme.name(),
        sim.params.h,
        sim.params.theta
    );
    println!("steps            {} to t = {:.6} s", st.steps, sim.state.t);
    println!("max penetration  {:.3e} m", st.max_penetration);
    println!("max active       {} contacts", st.max_active_contacts);
    if !sim.model.joints.is_empty() {
        println!(
            "joint violation  {:.3e} m, {:.3e} rad (max at step ends)",
            st.max_joint_violation, st.max_joint_angle_violation
        );
    }
    if sim.params.scheme != mc_study::integrator::Scheme::MoreauJean {
        println!(
            "projection       max {} iterations, max {} active-set passes, {} failures",
            st.max_projection_iterations, st.max_active_set_passes, st.projection_failures
        );
    }
    println!(
        "solver failures  {} steps (max residual {:.2e})",
        st.solver_failures, st.max_solver_residual
    );
    println!("newton failures  {} steps", st.newton_failures);
    println!(
        "wall time        {:.3} s ({:.3} µs/step)",
        wall.as_secs_f64(),
        wall.as_secs_f64() * 1e6 / st.steps.max(1) as f64
    );
    if let (Some(path), Some(fmt)) = (out, format) {
        match fmt {
            "csv" => traj.write_csv(path),
            _ => traj.write_parquet(path).map_err(std::io::Error::other),
        }
        .with_context(|| format!("writing {}", path.display()))?;
        println!(
            "trajectory       {} rows × {} columns → {}",
            traj.rows(),
            traj.columns.len(),
            path.display()
        );
    }
    result?;
    if st.solver_failures > 0 || st.newton_failures > 0 {
        eprintln!(
            "warning: {} step(s) did not converge; see the counts above",
            st.solver_failures + st.newton_failures
        );
    }
    Ok(())
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Simulate {
            scene,
            out,
            duration,
        } => simulate(scene, out.as_ref(), *duration),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::from(2)
        }
    }
}
