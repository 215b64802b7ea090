//! The time loop: contact activation, the velocity step, the position update and (for the
//! projected schemes) the position projection, with per-step diagnostics accumulated over
//! the run.

use super::moreau_jean::{advance_poses, velocity_step, VelocityStep};
use super::params::{IntegrationParameters, Scheme};
use super::projection::{inverse_mass, project, ContactRows, ProjectionOutcome};
use crate::mechanics::joint::{BilateralRow, RowUnit};
use crate::mechanics::model::{Candidate, State};
use crate::mechanics::{ContactPoint, Model, Pose};
use crate::solver::SolverStatus;
use nalgebra::{Matrix6, Vector3};

/// Diagnostics of one step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepReport {
    pub active_contacts: usize,
    pub newton_iterations: usize,
    pub newton_converged: bool,
    pub solver: SolverStatus,
    /// Velocity steps done (more than one when the combined scheme activated contacts).
    pub active_set_passes: usize,
    pub projection: ProjectionOutcome,
}

impl StepReport {
    /// Folds in the report of another part of the same step: the worst of each flag and
    /// residual, the work added.
    fn absorb(&mut self, part: &StepReport) {
        self.newton_converged &= part.newton_converged;
        self.newton_iterations += part.newton_iterations;
        self.solver.converged &= part.solver.converged;
        self.solver.residual = self.solver.residual.max(part.solver.residual);
        self.solver.iterations += part.solver.iterations;
        self.projection.converged &= part.projection.converged;
        self.projection.iterations = self.projection.iterations.max(part.projection.iterations);
        self.active_set_passes = self.active_set_passes.max(part.active_set_passes);
    }
}

/// The report of an impact (a velocity step of length 0, nothing projected).
fn impact_report(vs: &VelocityStep) -> StepReport {
    StepReport {
        active_contacts: vs.impulses.len(),
        newton_iterations: vs.newton_iterations,
        newton_converged: vs.newton_converged,
        solver: vs.solver,
        active_set_passes: 1,
        projection: ProjectionOutcome {
            converged: true,
            ..ProjectionOutcome::default()
        },
    }
}

/// A step computed from the current state, before it is taken.
struct Outcome {
    active: Vec<usize>,
    vs: VelocityStep,
    poses: Vec<Pose>,
    /// The contact points at `poses`, when the scheme evaluated them.
    points: Option<Vec<ContactPoint>>,
    /// Contacts the activation loop added (closing within the step), each with its gap at
    /// the end of the pass before it was added.
    closing: Vec<(usize, f64)>,
    report: StepReport,
}

/// Diagnostics accumulated over a run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RunStats {
    pub steps: u64,
    /// Largest −gap seen over all contact candidates at the step ends (m); 0 if none.
    pub max_penetration: f64,
    /// Largest joint anchor separation at the step ends (m).
    pub max_joint_violation: f64,
    /// Largest joint angle violation at the step ends (rad).
    pub max_joint_angle_violation: f64,
    /// Steps whose contact solver did not reach its tolerance.
    pub solver_failures: u64,
    /// Steps whose Newton loop did not reach its tolerance.
    pub newton_failures: u64,
    /// Steps whose projection did not reach its tolerance (or whose activation loop did not
    /// settle).
    pub projection_failures: u64,
    pub max_solver_residual: f64,
    pub max_active_contacts: usize,
    pub max_active_set_passes: usize,
    pub max_projection_iterations: usize,
    /// Steps split at an impact (`IntegrationParameters::locate_impacts`).
    pub impact_splits: u64,
}

#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum SimError {
    #[error("invalid integration parameter `{0}`: {1}")]
    Parameters(&'static str, String),
    #[error("the state became non-finite (NaN or infinite) at t = {t:.9} s, step {step}")]
    NonFinite { t: f64, step: u64 },
    #[error("modelling error at t = {t:.9} s: {message}")]
    Geometry { t: f64, message: String },
}

/// A guard enters the velocity problem only when the step would carry the journal past it
/// by more than this fraction of the clearance. A shallower crossing leaves the journal
/// within a few tenths of c outside its ring, which the projection removes in 2–3
/// iterations, and an extra contact next to a pressed ring point only makes the friction
/// problem harder: at μ = 1 on the pendulum, guards at depth 0 added 9 failed steps in
/// 0.2 s (c = 1 µm, h = 0.1 ms) where depth 0.5 adds none.
const GUARD_DEPTH: f64 = 0.5;

/// Normal speed (m/s) below which a pressed contact counts as staying closed.
const SEPARATION_SPEED: f64 = 1e-9;

/// Cloned where a run forks (`probe_run`): each copy then steps on its own.
#[derive(Clone)]
pub struct Simulation {
    pub model: Model,
    pub params: IntegrationParameters,
    pub state: State,
    candidates: Vec<Candidate>,
    /// Per candidate, the ring (2 × joint + side) of a clearance-joint guard
    /// (`ClearanceJoint::is_guard`); `None` for every other contact.
    guard_ring: Vec<Option<usize>>,
    /// Per candidate, whether it loses its friction while the mechanism settles.
    settle_frictionless: Vec<bool>,
    mask: Vec<bool>,
    minv: Vec<Matrix6<f64>>,
    points: Vec<ContactPoint>,
    impulses: Vec<Vector3<f64>>,
    joint_impulses: Vec<f64>,
    /// Candidates in the velocity problem of the last step.
    active: Vec<usize>,
    /// Size of the step being taken, or last taken: `params.h`, or the settle's step.
    h: f64,
    /// Time and step count when the step size last changed: t = t0 + (steps − n0) h.
    t0: f64,
    n0: u64,
    /// End of the refinement window (`Model::refine`) once its contact has closed.
    refine_until: Option<f64>,
    pub stats: RunStats,
}

impl Simulation {
    pub fn new(model: Model, params: IntegrationParameters) -> Result<Self, SimError> {
        params
            .validate()
            .map_err(|(f, m)| SimError::Parameters(f, m))?;
        let state = model.initial_state();
        let candidates = model.contact_candidates();
        let mask = model.dof_mask();
        let guard_ring: Vec<Option<usize>> = candidates
            .iter()
            .map(|c| match *c {
                Candidate::Clearance { joint, point }
                    if model.clearance_joints[joint].is_guard(point) =>
                {
                    let (side, _) = model.clearance_joints[joint].guard(point);
                    Some(2 * joint + usize::from(side > 0.0))
                }
                _ => None,
            })
            .collect();
        let settle_frictionless = candidates
            .iter()
            .map(|&c| model.frictionless_while_settling(c))
            .collect();
        let mut sim = Simulation {
            guard_ring,
            settle_frictionless,
            minv: inverse_mass(&model, &mask),
            mask,
            impulses: vec![Vector3::zeros(); candidates.len()],
            joint_impulses: Vec::new(),
            active: Vec::new(),
            points: Vec::new(),
            candidates,
            h: params.h,
            t0: state.t,
            n0: 0,
            refine_until: None,
            model,
            params,
            state,
            stats: RunStats::default(),
        };
        sim.update_geometry(None);
        Ok(sim)
    }

    /// Contact points, penetration and joint violations at the current poses; `points`, when
    /// given, are the contact points already evaluated there (the combined scheme's
    /// activation test evaluates them at the end-of-step poses).
    fn update_geometry(&mut self, points: Option<Vec<ContactPoint>>) {
        match points {
            Some(points) => self.points = points,
            None => {
                self.model
                    .evaluate_selected(&self.state.poses, &self.candidates, &mut self.points)
            }
        }
        for p in &self.points {
            self.stats.max_penetration = self.stats.max_penetration.max(-p.gap());
        }
        if !self.model.joints.is_empty() {
            let mut rows = Vec::new();
            for j in &self.model.joints {
                j.rows(self.state.t, &self.state.poses, &mut rows);
            }
            for r in rows {
                let s = &mut self.stats;
                match r.unit {
                    RowUnit::Length => {
                        s.max_joint_violation = s.max_joint_violation.max(r.value.abs())
                    }
                    RowUnit::Angle => {
                        s.max_joint_angle_violation = s.max_joint_angle_violation.max(r.value.abs())
                    }
                }
            }
        }
    }

    fn is_guard(&self, i: usize) -> bool {
        self.guard_ring[i].is_some()
    }

    /// Contact candidates evaluated at the current state, in `Model::contact_candidates` order.
    pub fn contact_points(&self) -> &[ContactPoint] {
        &self.points
    }

    /// What each contact point is (pair point or joint stop).
    pub fn contact_ids(&self) -> &[Candidate] {
        &self.candidates
    }

    /// Impulse (P_N, P_T1, P_T2) of each candidate over the last step (zero if inactive).
    pub fn impulses(&self) -> &[Vector3<f64>] {
        &self.impulses
    }

    /// Impulses of the joints' bilateral rows over the last step, in row order.
    pub fn joint_impulses(&self) -> &[f64] {
        &self.joint_impulses
    }

    pub fn energy(&self) -> f64 {
        self.model.energy(&self.state)
    }

    /// Size of the step being taken, or of the last one taken.
    pub fn h(&self) -> f64 {
        self.h
    }

    /// The end of the refinement window, once it has opened.
    pub fn refine_window_end(&self) -> Option<f64> {
        self.refine_until
    }

    /// Halves the refinement window's step from the next step on (the fine branch of an
    /// extrapolated window, `probe_run`).
    pub fn halve_refine_step(&mut self) {
        if let Some(r) = self.model.refine.as_mut() {
            r.step_ratio *= 0.5;
        }
    }

    /// The step that starts now, and the time it ends at when that is a phase's end: the
    /// settle's step while settling, the refinement window's within it, each phase's last
    /// step shortened or stretched (by at most 1e-9) to end at the phase's end; else h.
    fn next_step(&self) -> (f64, Option<f64>) {
        let t = self.state.t;
        let settle = self.model.settling(t);
        let window = self
            .refine_until
            .zip(self.model.refine.as_ref())
            .map(|(until, r)| (until, r.step_ratio * self.params.h))
            .filter(|&(until, h)| t < until - 1e-9 * h);
        match settle
            .and_then(|s| s.step_ratio.map(|r| (s.until, r * self.params.h)))
            .or(window)
        {
            Some((until, h)) if until - t <= h * (1.0 + 1e-9) => (until - t, Some(until)),
            Some((_, h)) => (h, None),
            None => (self.params.h, None),
        }
    }

    /// The integration parameters of the current step (h may be the settle's, and so may
    /// the solver's tolerance).
    fn step_params(&self) -> IntegrationParameters {
        let mut p = IntegrationParameters {
            h: self.h,
            ..self.params.clone()
        };
        if let Some(r) = self
            .model
            .settling(self.state.t)
            .and_then(|s| s.tolerance_ratio)
        {
            p.solver.tolerance *= r;
        }
        p
    }

    fn velocity(&self, active: &[usize]) -> VelocityStep {
        let t_mid = self.state.t + 0.5 * self.h;
        let joints = &self.model.joints;
        let rows_at = |poses: &[Pose]| {
            let mut rows = Vec::new();
            for j in joints {
                j.rows(t_mid, poses, &mut rows);
            }
            rows
        };
        // while settling, the contacts that lose their friction enter as copies with μ = 0
        let settling: Vec<ContactPoint>;
        let refs: Vec<&ContactPoint> = if self.model.settling(self.state.t).is_some() {
            settling = active
                .iter()
                .map(|&i| {
                    let mut c = self.points[i];
                    if self.settle_frictionless[i] {
                        c.mu = 0.0;
                    }
                    c
                })
                .collect();
            settling.iter().collect()
        } else {
            active.iter().map(|&i| &self.points[i]).collect()
        };
        // a guard's index names a point relative to the current closest point, so its last
        // impulse belongs to another point: start it cold
        let warm: Vec<Vector3<f64>> = active
            .iter()
            .map(|&i| {
                if self.is_guard(i) {
                    Vector3::zeros()
                } else {
                    self.impulses[i]
                }
            })
            .collect();
        velocity_step(
            &self.model,
            &self.mask,
            &self.step_params(),
            self.state.t,
            &self.state.poses,
            &self.state.v,
            &refs,
            &warm,
            (!joints.is_empty()).then_some(&rows_at as &dyn Fn(&[Pose]) -> Vec<BilateralRow>),
        )
    }

    /// Projects `poses` at t + h: joints, plus those of the candidates `pool` (ascending
    /// indices) that `which` chooses, given their contact points at those poses.
    fn project_poses(
        &self,
        poses: &mut [Pose],
        pool: &[usize],
        which: &dyn Fn(usize, &ContactPoint) -> bool,
        mode: ContactRows,
    ) -> ProjectionOutcome {
        let model = &self.model;
        let candidates: Vec<Candidate> = pool.iter().map(|&i| self.candidates[i]).collect();
        let points = |ps: &[Pose]| -> Vec<ContactPoint> {
            let mut pts = Vec::with_capacity(pool.len());
            model.evaluate_selected(ps, &candidates, &mut pts);
            pool.iter()
                .zip(pts)
                .filter(|(&i, cp)| which(i, cp))
                .map(|(_, cp)| cp)
                .collect()
        };
        project(
            model,
            &self.mask,
            &self.minv,
            self.state.t + self.h,
            poses,
            &points,
            mode,
            self.params.projection_tolerance,
            self.params.projection_max_iterations,
        )
    }

    /// Advances one step of size h (the settle's step while settling). With
    /// `locate_impacts`, a step in which a contact closes is redone at the closing time
    /// (`split_at_impact`).
    pub fn step(&mut self) -> Result<StepReport, SimError> {
        let (h, ends_at) = self.next_step();
        if h != self.h {
            self.h = h;
            self.t0 = self.state.t;
            self.n0 = self.stats.steps;
        }
        let t_end = ends_at.unwrap_or(self.t0 + (self.stats.steps + 1 - self.n0) as f64 * h);
        let trial = self.compute()?;
        let impact = match self.params.locate_impacts {
            true => self.first_impact(&trial),
            false => None,
        };
        let report = match impact {
            None => self.commit(trial, t_end),
            Some((i, s)) => self.split_at_impact(i, s, &trial.active, t_end)?,
        };
        self.stats.steps += 1;
        // the refinement window opens at the end of the step in which its contact closed
        if let (None, Some(r)) = (self.refine_until, &self.model.refine) {
            if r.trigger.iter().any(|&i| self.impulses[i].x > 0.0) {
                self.refine_until = Some(self.state.t + r.duration);
            }
        }
        let s = &mut self.stats;
        s.solver_failures += u64::from(!report.solver.converged);
        s.newton_failures += u64::from(!report.newton_converged);
        let projected = self.params.scheme != Scheme::MoreauJean;
        s.projection_failures += u64::from(projected && !report.projection.converged);
        s.max_solver_residual = s.max_solver_residual.max(report.solver.residual);
        s.max_active_contacts = s.max_active_contacts.max(report.active_contacts);
        s.max_active_set_passes = s.max_active_set_passes.max(report.active_set_passes);
        s.max_projection_iterations = s
            .max_projection_iterations
            .max(report.projection.iterations);
        Ok(report)
    }

    /// The earliest contact that closes within the step `trial` computed, and the fraction
    /// of the step at which it closes: its gap interpolated linearly between the step's
    /// start and the end of the pass that activated it. `None` without one.
    fn first_impact(&self, trial: &Outcome) -> Option<(usize, f64)> {
        trial
            .closing
            .iter()
            .filter_map(|&(i, end_gap)| {
                let g0 = self.points[i].gap();
                (g0 > 0.0 && end_gap < 0.0).then(|| (i, g0 / (g0 - end_gap)))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// The step redone in three parts: up to the impact of contact `i` at fraction `s` of
    /// the step, the impact itself (a step of length 0: the frictional impact law alone, on
    /// the contacts that the whole step closed and those touching then), and the rest of
    /// the step from the post-impact velocity. The θ-rule would otherwise move the bodies over the whole step with the
    /// mean of the pre- and post-impact velocities, which misplaces them by up to h/2 times
    /// the velocity jump, whatever h resolves elsewhere. The step's impulses are the sums
    /// of its parts', so that impulse / h stays the step's mean force.
    fn split_at_impact(
        &mut self,
        i: usize,
        s: f64,
        in_step: &[usize],
        t_end: f64,
    ) -> Result<StepReport, SimError> {
        let (h, t_start) = (self.h, self.state.t);
        let mut impulses = vec![Vector3::zeros(); self.points.len()];
        let add = |sim: &Simulation, sum: &mut Vec<Vector3<f64>>| {
            sum.iter_mut().zip(&sim.impulses).for_each(|(a, b)| *a += b);
        };
        // The part before ends a hair (1e-6 of it) short of the contact, which it must not
        // close itself; where the gap's curvature over the step put the estimate past the
        // contact, the secant on the part just computed corrects it. A part shorter than
        // 1e-3 h misplaces the bodies by at most 1e-3 h times the jump.
        let g0 = self.points[i].gap();
        let mut s = s * (1.0 - 1e-6);
        let mut tries = 0;
        let before = loop {
            s = s.clamp(1e-3, 1.0 - 1e-3);
            self.h = s * h;
            let part = self.compute()?;
            tries += 1;
            match part.closing.iter().find(|c| c.0 == i) {
                Some(&(_, end_gap)) if s > 1e-3 && tries < 4 => {
                    s *= g0 / (g0 - end_gap) * (1.0 - 1e-6)
                }
                _ => break part,
            }
        };
        let first = self.commit(before, t_start + s * h);
        add(self, &mut impulses);
        let mut joint_impulses = self.joint_impulses.clone();
        // The impact, at the poses it happens at, on the contacts of the whole step as the
        // unsplit step had them (`in_step`, with the guards that stop a journal crossing
        // its clearance), those of the part before, and every one that touches then (a gap
        // no wider than the impacting contact's, plus the activation margin): the contacts
        // the step closes take its impact together, as Moreau's law has them, not one after
        // the other. Contacts that close together (the two rings of a journal swinging in
        // its plane, a box's corners) and a journal that the blow drives across a tiny
        // clearance (which an ideal joint takes in the same impulse) need it: taken one
        // after the other, with e = 0, they lose other momenta.
        self.h = 0.0;
        let margin = self.params.activation_margin + self.points[i].gap().max(0.0);
        let mut member = vec![false; self.points.len()];
        in_step.iter().for_each(|&k| member[k] = true);
        self.active
            .iter()
            .for_each(|&k| member[k] |= !self.is_guard(k));
        let active: Vec<usize> = (0..self.points.len())
            .filter(|&k| {
                member[k] || k == i || (!self.is_guard(k) && self.points[k].gap() <= margin)
            })
            .collect();
        let vs = self.velocity(&active);
        if vs.v.iter().any(|x| !x.is_finite()) {
            return Err(SimError::NonFinite {
                t: self.state.t,
                step: self.stats.steps,
            });
        }
        self.impulses.iter_mut().for_each(|x| *x = Vector3::zeros());
        for (&k, imp) in active.iter().zip(&vs.impulses) {
            self.impulses[k] = *imp;
        }
        add(self, &mut impulses);
        let impact = impact_report(&vs);
        self.active = active;
        self.state.v = vs.v;
        self.h = (1.0 - s) * h;
        let after = self.compute()?;
        let mut report = self.commit(after, t_end);
        add(self, &mut impulses);
        self.impulses = impulses;
        if joint_impulses.len() == self.joint_impulses.len() {
            let add_rows = |a: &mut Vec<f64>, b: &[f64]| {
                a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
            };
            add_rows(&mut joint_impulses, &vs.joint_impulses);
            add_rows(&mut joint_impulses, &self.joint_impulses);
            self.joint_impulses = joint_impulses;
        }
        self.h = h;
        for part in [&first, &impact] {
            report.absorb(part);
        }
        self.stats.impact_splits += 1;
        Ok(report)
    }

    /// The step of size `self.h` from the current state, not yet taken.
    fn compute(&self) -> Result<Outcome, SimError> {
        let p = self.step_params();
        for j in &self.model.clearance_joints {
            j.check(&self.state.poses)
                .map_err(|message| SimError::Geometry {
                    t: self.state.t,
                    message,
                })?;
        }
        let v0 = &self.state.v;
        let forecast = |c: &ContactPoint| {
            c.gap() + p.gamma * p.h * c.local_velocity(v0.as_slice()).x <= p.activation_margin
        };
        let mut report = StepReport::default();
        let outcome = match p.scheme {
            Scheme::MoreauJean | Scheme::DirectProjection => {
                let active: Vec<usize> = (0..self.points.len())
                    .filter(|&i| forecast(&self.points[i]))
                    .collect();
                let vs = self.velocity(&active);
                let mut poses = advance_poses(&self.state.poses, v0, &vs.v, p.h, p.theta);
                report.active_set_passes = 1;
                if p.scheme == Scheme::DirectProjection {
                    report.projection = self.project_poses(
                        &mut poses,
                        &active,
                        &|_, _| true,
                        ContactRows::Inequality,
                    );
                }
                Outcome {
                    active,
                    vs,
                    poses,
                    points: None,
                    closing: Vec::new(),
                    report,
                }
            }
            Scheme::CombinedProjection => self.combined(report),
        };
        if outcome.vs.v.iter().any(|x| !x.is_finite())
            || outcome
                .poses
                .iter()
                .any(|q| !q.x.iter().all(|x| x.is_finite()))
        {
            return Err(SimError::NonFinite {
                t: self.state.t,
                step: self.stats.steps,
            });
        }
        for j in &self.model.clearance_joints {
            j.check(&outcome.poses)
                .map_err(|message| SimError::Geometry {
                    t: self.state.t + p.h,
                    message,
                })?;
        }
        Ok(outcome)
    }

    /// Takes the computed step: the state at time `t`, its impulses and contact points.
    fn commit(&mut self, outcome: Outcome, t: f64) -> StepReport {
        let Outcome {
            active,
            vs,
            poses,
            points,
            mut report,
            ..
        } = outcome;
        self.impulses.iter_mut().for_each(|x| *x = Vector3::zeros());
        for (&i, imp) in active.iter().zip(&vs.impulses) {
            self.impulses[i] = *imp;
        }
        self.joint_impulses = vs.joint_impulses;
        self.active = active;
        self.state = State { t, poses, v: vs.v };
        self.update_geometry(points);
        report.active_contacts = self.active.len();
        report.newton_iterations = vs.newton_iterations;
        report.newton_converged = vs.newton_converged;
        report.solver = vs.solver;
        report
    }

    /// The combined projection + activation loop (`moreau_jean.md` §4.3), started from the
    /// previous step's active set (kept while pressed or closed; guards are not kept, they
    /// are chosen afresh each step): the active set, the velocity step, the end-of-step
    /// poses, the contact points evaluated there, and the contacts that closed.
    fn combined(&self, mut report: StepReport) -> Outcome {
        let p = &self.step_params();
        let mut closing = Vec::new();
        let mut active: Vec<usize> = self
            .active
            .iter()
            .copied()
            .filter(|&i| !self.is_guard(i))
            .filter(|&i| self.impulses[i].x > 0.0 || self.points[i].gap() <= p.activation_margin)
            .collect();
        let (mut last, mut settled) = (None, false);
        for pass in 1..=p.max_active_set_passes {
            let vs = self.velocity(&active);
            let mut in_active = vec![false; self.points.len()];
            active.iter().for_each(|&i| in_active[i] = true);
            // A guard whose linearised end-of-step gap g + h u_N,θ is negative marks a step
            // that carries the journal across its clearance: put the most crossed guard of
            // each such ring in the velocity problem and solve again (the guards are far from
            // contact otherwise, so this never happens while h·v stays below the clearance).
            // One per ring and pass keeps the problem small and its Delassus matrix regular.
            let mut worst: Vec<(usize, usize, f64)> = Vec::new(); // (ring, candidate, gap)
            for (i, ring) in self.guard_ring.iter().enumerate() {
                let Some(ring) = *ring else { continue };
                if in_active[i] {
                    continue;
                }
                let c = &self.points[i];
                let u0 = c.local_velocity(self.state.v.as_slice()).x;
                let u1 = c.local_velocity(vs.v.as_slice()).x;
                let end_gap = c.gap() + p.h * ((1.0 - p.theta) * u0 + p.theta * u1);
                if end_gap < -GUARD_DEPTH * self.model.clearance_joints[ring / 2].clearance {
                    match worst.iter_mut().find(|w| w.0 == ring) {
                        Some(w) if end_gap < w.2 => *w = (ring, i, end_gap),
                        Some(_) => {}
                        None => worst.push((ring, i, end_gap)),
                    }
                }
            }
            let crossing: Vec<usize> = worst.iter().map(|w| w.1).collect();
            if !crossing.is_empty() && pass < p.max_active_set_passes {
                active.extend(crossing);
                active.sort_unstable();
                continue;
            }
            let mut poses = advance_poses(&self.state.poses, &self.state.v, &vs.v, p.h, p.theta);
            // Project onto g = 0, as equalities, the active contacts that penetrate and those
            // that stay closed (pressed, not separating: u_N,k+1 ≤ e|u_N,k|/2). A contact that
            // rebounds (e > 0) and ended with g > 0 is left where it is: pulling it down onto
            // the surface (as Siconos' combined scheme does with every active contact) throws
            // away m g·g of energy per impact, 60 % at e = 1 and h = 0.05 on the ball.
            let mut closed = vec![false; self.points.len()];
            for (k, &i) in active.iter().enumerate() {
                let c = &self.points[i];
                let u0 = c.local_velocity(self.state.v.as_slice()).x;
                let u1 = c.local_velocity(vs.v.as_slice()).x;
                closed[i] =
                    vs.impulses[k].x > 0.0 && u1 <= 0.5 * c.e * (-u0).max(0.0) + SEPARATION_SPEED;
            }
            let pool: Vec<usize> = active
                .iter()
                .copied()
                .filter(|&i| self.guard_ring[i].is_none())
                .collect();
            let selected = |i: usize, cp: &ContactPoint| closed[i] || cp.gap() < 0.0;
            report.projection =
                self.project_poses(&mut poses, &pool, &selected, ContactRows::Equality);
            report.active_set_passes = pass;
            // activation from the end-of-step position
            let mut after = Vec::new();
            self.model
                .evaluate_selected(&poses, &self.candidates, &mut after);
            let new: Vec<usize> = (0..after.len())
                .filter(|&i| !in_active[i] && !self.is_guard(i) && after[i].gap() <= 0.0)
                .collect();
            if new.is_empty() {
                settled = true;
                last = Some((active, vs, poses, after));
                break;
            }
            closing.extend(new.iter().map(|&i| (i, after[i].gap())));
            last = Some((active.clone(), vs, poses, after));
            active.extend(new);
            active.sort_unstable();
        }
        // an active set that did not settle within the allowed passes keeps the last pass,
        // flagged
        report.projection.converged &= settled;
        let (active, vs, poses, after) = last.expect("at least one pass");
        Outcome {
            active,
            vs,
            poses,
            points: Some(after),
            closing,
            report,
        }
    }

    /// Whether a run to `t_end` is over: `t_end` is nearer than half the next step.
    pub fn reached(&self, t_end: f64) -> bool {
        self.state.t >= t_end - 0.5 * self.next_step().0
    }

    /// Steps until `t_end` (to the nearest step), calling `observe` after every step.
    pub fn run_until(
        &mut self,
        t_end: f64,
        mut observe: impl FnMut(&Simulation, &StepReport),
    ) -> Result<(), SimError> {
        while !self.reached(t_end) {
            let r = self.step()?;
            observe(self, &r);
        }
        Ok(())
    }
}
