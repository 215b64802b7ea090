//! One run of a scene (what `mc-study simulate` does), with its diagnostics, its probes,
//! and on request its trajectory (CSV or Parquet, `trajectory`) and a drawing of the
//! mechanism at chosen times (`drawing`). The run and what it measured make a
//! [`SimulateReport`], which prints as the command's output.

pub mod drawing;
pub mod trajectory;

use crate::input::units::Dim;
use crate::integrator::{RunStats, Scheme, Simulation};
use crate::probe::run::{run_probes, Branch};
use crate::scene::Scene;
use anyhow::{Context, Result};
use drawing::{Snapshot, View};
use std::fmt;
use std::path::PathBuf;
use std::time::Instant;
use trajectory::Trajectory;

/// What to draw: an SVG file, its snapshot times (s, ascending) and the view.
#[derive(Clone, Debug)]
pub struct DrawingRequest {
    pub path: PathBuf,
    pub times: Vec<f64>,
    pub view: View,
}

impl DrawingRequest {
    /// The drawing `--svg FILE --snapshots T1,T2 --view V` asks for: times with units
    /// (`2ms`) between 0 and `duration`, the start and the end by default.
    pub fn parse(
        svg: PathBuf,
        snapshots: &[String],
        view: &str,
        duration: f64,
    ) -> Result<DrawingRequest, String> {
        let view = View::parse(view)
            .ok_or_else(|| format!("--view must be xy, xz or yz, got `{view}`"))?;
        let mut times = Vec::new();
        for s in snapshots {
            let q = crate::input::units::parse_quantity(s)
                .map_err(|e| format!("--snapshots {s}: {e}"))?;
            if q.dim.is_some_and(|d| d != Dim::TIME) || !(0.0..=duration).contains(&q.si) {
                return Err(format!(
                    "--snapshots {s}: expected a time between 0 and the duration ({duration} s)"
                ));
            }
            times.push(q.si);
        }
        if times.is_empty() {
            times = vec![0.0, duration];
        }
        times.sort_by(f64::total_cmp);
        Ok(DrawingRequest {
            path: svg,
            times,
            view,
        })
    }
}

/// Options of a run besides the scene.
#[derive(Clone, Debug, Default)]
pub struct SimulateOptions {
    /// Simulated time span (default: the scene's duration).
    pub duration: Option<f64>,
    /// Where the trajectory goes: `.csv` or `.parquet`.
    pub trajectory: Option<PathBuf>,
    pub drawing: Option<DrawingRequest>,
}

/// Per-step work summed over the run: Newton iterations, solver iterations (of the last Newton
/// iteration), activation passes and active contacts.
#[derive(Clone, Copy, Debug, Default)]
struct Work {
    newton: u64,
    sweeps: u64,
    passes: u64,
    contacts: u64,
}

/// One probe's outcome, in the unit the scene asks for.
#[derive(Clone, Debug)]
pub struct ProbeValue {
    pub name: String,
    /// SI value, or why there is none.
    pub value: Result<f64, String>,
    pub unit: String,
    /// (label, display value) when the probe declares a display unit.
    pub display: Option<(String, f64)>,
    pub caution: Option<String>,
}

/// A curve probe's outcome: its grid and values (SI), and the file it was written to.
#[derive(Clone, Debug)]
pub struct CurveValues {
    pub name: String,
    pub x: String,
    pub x_unit: String,
    pub unit: String,
    /// (grid point, value) where x entered the cell; NaN where it did not.
    pub points: Vec<(f64, f64)>,
    pub file: Option<PathBuf>,
}

/// Where `simulate --out PATH` writes curve `name`: beside the trajectory, `STEM.NAME.csv`.
fn curve_path(trajectory: &std::path::Path, name: &str) -> PathBuf {
    let stem = trajectory.file_stem().unwrap_or_default().to_string_lossy();
    trajectory.with_file_name(format!("{stem}.{name}.csv"))
}

/// What a run did and measured.
#[derive(Clone, Debug)]
pub struct SimulateReport {
    pub scene: String,
    pub source: String,
    /// How the written state was assembled.
    pub assembly: crate::integrator::assembly::Assembly,
    pub scheme: Scheme,
    pub h: f64,
    pub settle_h: Option<f64>,
    /// The step-size control, if the run had one (h is then its first step).
    pub step_control: Option<crate::integrator::StepControl>,
    pub theta: f64,
    pub t_end: f64,
    pub stats: RunStats,
    /// Where the refinement window forked, and its coarse and fine steps.
    pub extrapolated: Option<(f64, f64, f64)>,
    /// The refinement window's start, end (the run's end if it was still open) and step,
    /// if it opened.
    pub window: Option<(f64, f64, f64)>,
    pub has_joints: bool,
    /// Whether the scene has rigid unilateral contacts (pairs, stops, clearance joints).
    pub has_contacts: bool,
    pub locate_impacts: bool,
    work: Work,
    pub wall_seconds: f64,
    /// (rows, columns, path) of the trajectory written.
    pub trajectory: Option<(usize, usize, PathBuf)>,
    /// (snapshots, path) of the drawing written.
    pub drawing: Option<(usize, PathBuf)>,
    pub probes: Vec<ProbeValue>,
    pub curves: Vec<CurveValues>,
    /// The failure that ended the run early, if any.
    pub error: Option<String>,
    /// The deepest overlap at t = 0 beyond what the scheme admits: what, and how deep (m).
    pub overlap: Option<(String, f64)>,
}

/// Runs `scene` (`source` names it in the report) with `options`, writing the trajectory
/// and the drawing it asks for.
pub fn simulate(scene: &Scene, source: &str, options: &SimulateOptions) -> Result<SimulateReport> {
    let duration = options.duration.unwrap_or(scene.duration);
    let every = scene.record_every as u64;
    let sim = scene.simulation()?;
    let overlap = sim.deepest_overlap();
    let h = sim.params.h;
    let drawing = options.drawing.as_ref();
    let mut snapshots: Vec<Snapshot> = Vec::new();
    let mut take_snapshots = |s: &Simulation| {
        if let Some(d) = drawing {
            while let Some(&t) = d.times.get(snapshots.len()) {
                if s.state.t < t - 0.5 * h {
                    break;
                }
                snapshots.push(Snapshot {
                    t: s.state.t,
                    poses: s.state.poses.clone(),
                });
            }
        }
    };
    take_snapshots(&sim);
    let recording = options.trajectory.is_some();
    let mut traj = Trajectory::for_simulation(&sim, &scene.probes);
    traj.record(&sim);
    let start = Instant::now();
    // the trajectory and the drawing follow the main (fine) branch; the work counts both
    let mut work = Work::default();
    let run = run_probes(
        sim,
        &scene.probes,
        &scene.curves,
        duration,
        false,
        |s, r, branch| {
            if branch == Branch::Main {
                if recording && s.stats.steps % every == 0 {
                    traj.record(s);
                }
                take_snapshots(s);
            }
            work.newton += r.newton_iterations as u64;
            work.sweeps += r.solver.iterations as u64;
            work.passes += r.active_set_passes as u64;
            work.contacts += r.active_contacts as u64;
        },
    );
    let wall_seconds = start.elapsed().as_secs_f64();
    let sim = &run.sim;
    let trajectory = match &options.trajectory {
        None => None,
        Some(path) => {
            match path.extension().and_then(|e| e.to_str()) {
                Some("csv") => traj.write_csv(path),
                _ => traj.write_parquet(path).map_err(std::io::Error::other),
            }
            .with_context(|| format!("writing {}", path.display()))?;
            Some((traj.rows(), traj.columns.len(), path.clone()))
        }
    };
    let drawing = match drawing {
        None => None,
        Some(d) => {
            let title = format!("{} ({source})", scene.name);
            std::fs::write(
                &d.path,
                drawing::svg(&scene.model, &snapshots, d.view, &title),
            )
            .with_context(|| format!("writing {}", d.path.display()))?;
            Some((snapshots.len(), d.path.clone()))
        }
    };
    let mut curves = Vec::new();
    for (c, values) in scene.curves.iter().zip(&run.curves) {
        let points: Vec<(f64, f64)> = values
            .iter()
            .enumerate()
            .map(|(i, y)| (c.grid.point(i), *y))
            .collect();
        let file = match &options.trajectory {
            None => None,
            Some(path) => {
                let file = curve_path(path, &c.name);
                let header = format!("{} [{}], {} [{}]", c.x_name, c.x_unit, c.name, c.unit)
                    .replace(" [1]", "");
                let with: Vec<(f64, f64)> =
                    points.iter().copied().filter(|p| p.1.is_finite()).collect();
                let text = crate::study::curves::points_csv(&header, &with);
                std::fs::write(&file, text)
                    .with_context(|| format!("writing {}", file.display()))?;
                Some(file)
            }
        };
        curves.push(CurveValues {
            name: c.name.clone(),
            x: c.x_name.clone(),
            x_unit: c.x_unit.clone(),
            unit: c.unit.clone(),
            points,
            file,
        });
    }
    let refine = sim.schedule.refine.as_ref();
    let probes = scene
        .probes
        .iter()
        .zip(run.values)
        .map(|(p, value)| ProbeValue {
            name: p.name.clone(),
            display: match (&p.display, &value) {
                (Some(d), Ok(v)) => Some((d.label.clone(), d.of(*v))),
                _ => None,
            },
            value,
            unit: p.unit.clone(),
            caution: p.caution.clone(),
        })
        .collect();
    Ok(SimulateReport {
        scene: scene.name.clone(),
        source: source.to_string(),
        assembly: scene.assembly.clone(),
        scheme: sim.params.scheme,
        h: sim.params.h,
        settle_h: sim
            .schedule
            .settle
            .as_ref()
            .and_then(|s| s.step_ratio)
            .map(|r| r * sim.params.h),
        step_control: sim.params.step_control.clone(),
        theta: sim.params.theta,
        t_end: sim.state.t,
        stats: run.stats,
        extrapolated: run.forked_at.zip(refine).map(|(t, r)| {
            let fine = r.step_ratio * sim.params.h;
            (t, 2.0 * fine, fine)
        }),
        window: sim
            .refine_window()
            .zip(refine)
            .map(|((from, to), r)| (from, to.min(sim.state.t), r.step_ratio * sim.params.h)),
        has_joints: !sim.model.joints.is_empty(),
        has_contacts: !sim.contact_ids().is_empty(),
        locate_impacts: sim.params.locate_impacts,
        work,
        wall_seconds,
        trajectory,
        drawing,
        probes,
        curves,
        error: run.error.map(|e| match &overlap {
            // the modelling error, not its symptom, comes first
            Some((what, depth)) => format!(
                "bodies overlap at t = 0: {what}, by {depth:.3e} m; the run then failed: {e}"
            ),
            None => e,
        }),
        overlap,
    })
}

impl SimulateReport {
    /// Steps whose solver or Newton loop did not converge.
    pub fn nonconverged_steps(&self) -> u64 {
        self.stats.solver_failures + self.stats.newton_failures
    }
}

impl fmt::Display for SimulateReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let st = &self.stats;
        writeln!(f, "scene            {} ({})", self.scene, self.source)?;
        write!(f, "{}", self.assembly)?;
        if let Some((what, depth)) = &self.overlap {
            writeln!(
                f,
                "overlap          at t = 0: {what}, by {depth:.3e} m (check the written positions)"
            )?;
        }
        writeln!(
            f,
            "scheme           {} h = {:e} s{}, θ = {}",
            self.scheme.name(),
            self.h,
            self.settle_h
                .map_or(String::new(), |h| format!(" (settling: {h:e} s)")),
            self.theta
        )?;
        writeln!(
            f,
            "steps            {} to t = {:.6} s",
            st.steps, self.t_end
        )?;
        if let Some(c) = &self.step_control {
            writeln!(
                f,
                "step control     τ = {:e} (length {:e} m, speed {:e} m/s), h from {:e} to {:e} s, the first {:e} s: {} steps taken again",
                c.tolerance, c.length, c.speed, c.h_min, c.h_max, self.h, st.rejected_steps
            )?;
        }
        if let Some((from, to, h)) = self.window {
            writeln!(
                f,
                "window           h = {h:e} s from t = {from:.6} s to {to:.6} s (refine)"
            )?;
        }
        if let Some((t, coarse, fine)) = self.extrapolated {
            writeln!(
                f,
                "extrapolated     from t = {t:.6} s the refinement window was run at h = {coarse:e} s and {fine:e} s (the trajectory); probes = 2 f(fine) − f(coarse)"
            )?;
        }
        writeln!(f, "max penetration  {:.3e} m", st.max_penetration)?;
        writeln!(f, "max active       {} contacts", st.max_active_contacts)?;
        if self.has_joints {
            writeln!(
                f,
                "joint violation  {:.3e} m, {:.3e} rad (max at step ends)",
                st.max_joint_violation, st.max_joint_angle_violation
            )?;
        }
        if self.scheme.projects() {
            writeln!(
                f,
                "projection       max {} iterations, max {} active-set passes, {} failures",
                st.max_projection_iterations, st.max_active_set_passes, st.projection_failures
            )?;
        }
        writeln!(
            f,
            "solver failures  {} steps (max residual {:.2e})",
            st.solver_failures, st.max_solver_residual
        )?;
        writeln!(f, "newton failures  {} steps", st.newton_failures)?;
        if self.locate_impacts {
            writeln!(f, "impacts located  {} steps split", st.impact_splits)?;
        } else if self.has_contacts {
            let remedy = match self.scheme {
                Scheme::CombinedProjection => "`locate_impacts: true` places each at its instant",
                _ => "`scheme: combined-projection` with `locate_impacts: true` places each at its instant",
            };
            writeln!(
                f,
                "impacts          at step ends: the bodies may be up to h/2 times each velocity jump off (a bounce's apex by up to (1 + e) v h / 2); {remedy}"
            )?;
        }
        if st.halved_steps > 0 {
            writeln!(
                f,
                "halved steps     {} (the contact or projection problem was not solved, or a journal would have left its bore)",
                st.halved_steps
            )?;
        }
        if st.squeezed_steps > 0 {
            writeln!(
                f,
                "squeezed         {} steps left a journal pushed from both sides of a ring: the step is too coarse for the joint (lower h)",
                st.squeezed_steps
            )?;
        }
        if st.plastic_steps > 0 {
            writeln!(
                f,
                "plastic impacts  {} steps (the contacts jammed, where restitution could add energy: e = 0 there)",
                st.plastic_steps
            )?;
        }
        let per_step = |w: u64| w as f64 / st.steps.max(1) as f64;
        writeln!(
            f,
            "work per step    {:.2} Newton iterations, {:.1} solver iterations, {:.2} activation passes, {:.1} active contacts (means)",
            per_step(self.work.newton),
            per_step(self.work.sweeps),
            per_step(self.work.passes),
            per_step(self.work.contacts)
        )?;
        writeln!(
            f,
            "wall time        {:.3} s ({:.3} µs/step)",
            self.wall_seconds,
            self.wall_seconds * 1e6 / st.steps.max(1) as f64
        )?;
        if let Some((rows, columns, path)) = &self.trajectory {
            writeln!(
                f,
                "trajectory       {rows} rows × {columns} columns → {}",
                path.display()
            )?;
        }
        if let Some((n, path)) = &self.drawing {
            writeln!(f, "drawing          {n} snapshot(s) → {}", path.display())?;
        }
        if self.error.is_none() && !self.probes.is_empty() {
            writeln!(f, "probes")?;
            let width = self.probes.iter().map(|p| p.name.len()).max().unwrap_or(0);
            for p in &self.probes {
                let flag = if p.caution.is_some() { " (!)" } else { "" };
                match (&p.value, &p.display) {
                    (Ok(_), Some((label, v))) => {
                        writeln!(f, "  {:width$}  {v:.9e} {label}{flag}", p.name)?
                    }
                    (Ok(v), None) => writeln!(f, "  {:width$}  {v:.9e} {}{flag}", p.name, p.unit)?,
                    (Err(e), _) => writeln!(f, "  {:width$}  none: {e}", p.name)?,
                }
            }
            for p in &self.probes {
                if let Some(c) = &p.caution {
                    writeln!(f, "(!) {}: {c}", p.name)?;
                }
            }
        }
        if self.error.is_none() && !self.curves.is_empty() {
            writeln!(f, "curves")?;
            for c in &self.curves {
                let with: Vec<&(f64, f64)> = c.points.iter().filter(|p| p.1.is_finite()).collect();
                let (lo, hi) = with
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                        (a.min(p.1), b.max(p.1))
                    });
                let unit = |u: &str| {
                    if u == "1" {
                        String::new()
                    } else {
                        format!(" {u}")
                    }
                };
                write!(
                    f,
                    "  {}  {} of {} grid points of {} have a value",
                    c.name,
                    with.len(),
                    c.points.len(),
                    c.x
                )?;
                if !with.is_empty() {
                    write!(f, ", from {lo:.6e} to {hi:.6e}{}", unit(&c.unit))?;
                }
                match &c.file {
                    Some(p) => writeln!(f, " → {}", p.display())?,
                    None => writeln!(f, " (--out writes it)")?,
                }
            }
        }
        Ok(())
    }
}
