//! The time loop: each step's size (the schedule's phases), contact activation, the
//! velocity step, the position update and (for the projected schemes) the position
//! projection, with per-step diagnostics accumulated over the run. The combined scheme's
//! activation loop is in `activation.rs`, the splitting of a step at an impact in
//! `impact.rs`, the step-size control in `step_control.rs`.

use super::elimination::Elimination;
use super::moreau_jean::{
    velocity_step, ActiveAt, ActiveContact, JointRowsAt, StepStart, VelocityStep, ROW_TURN,
};
use super::params::{IntegrationParameters, Scheme};
use super::projection::{
    inverse_mass, mass_distance_of_length, project, within_reach, ChordStep, ContactRows,
    ContactRowsOf, JointViolation, ProjectionOutcome,
};
use super::rollback::Rollback;
use super::schedule::Schedule;
use super::sinking::Sinking;
use super::step_control::{Controller, StepControl, Taken, Verdict, SHRINK_MAX};
use super::subdivision::Depth;
use super::workspace::{ProjectionWorkspace, StepWorkspace, VelocityWorkspace};
use crate::mechanics::contact::clearance::Placements;
use crate::mechanics::joint::BilateralRow;
use crate::mechanics::model::{Candidate, State};
use crate::mechanics::{ContactPoint, Model, Pose};
use crate::solver::SolverStatus;
use nalgebra::{DVector, Matrix6, Vector3};
use std::cell::RefCell;

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
    /// Its impacts were taken plastic: with restitution, the contacts jammed.
    pub plastic: bool,
}

impl StepReport {
    /// Folds in the report of another part of the same step: the worst of each flag and
    /// residual, the work added.
    pub(super) fn absorb(&mut self, part: &StepReport) {
        self.newton_converged &= part.newton_converged;
        self.newton_iterations += part.newton_iterations;
        self.solver.converged &= part.solver.converged;
        self.solver.residual = self.solver.residual.max(part.solver.residual);
        self.solver.iterations += part.solver.iterations;
        self.projection.converged &= part.projection.converged;
        self.projection.iterations = self.projection.iterations.max(part.projection.iterations);
        self.active_set_passes = self.active_set_passes.max(part.active_set_passes);
        self.plastic |= part.plastic;
    }
}

/// A step computed from the current state, before it is taken.
pub(super) struct Outcome {
    pub(super) active: Vec<usize>,
    pub(super) vs: VelocityStep,
    pub(super) poses: Vec<Pose>,
    /// The contact points at `poses`, when the scheme evaluated them: of the clearance
    /// guards, their gaps alone (`Simulation::guards_evaluated`).
    pub(super) points: Option<Vec<ContactPoint>>,
    /// Contacts the activation loop added (closing within the step).
    pub(super) closing: Vec<Closing>,
    /// The contact pairs' points the step sinks into their parts (`sinking.rs`).
    pub(super) sinking: Vec<Sinking>,
    pub(super) report: StepReport,
}

/// A contact that closes within a step.
#[derive(Clone, Copy, Debug)]
pub(super) struct Closing {
    pub(super) candidate: usize,
    /// Its gap at the end of the pass before it was added.
    pub(super) end_gap: f64,
    /// Closed by another contact's impulse within the step (the motion without the step's
    /// new impulses leaves it open): an impact that follows another, not one that happens
    /// with it.
    pub(super) knocked: bool,
}

/// The first impact located within a step (`IntegrationParameters::locate_impacts`): when
/// it happened, the state at that instant with the velocities just before it, the
/// velocities just after it, and the contacts that took it. A probe reads a value at a
/// time within the step through it, where interpolating between the step's ends would cut
/// the corner the impact puts in the motion.
#[derive(Clone, Debug)]
pub struct LocatedImpact {
    pub before: State,
    pub v_after: DVector<f64>,
    pub contacts: Vec<usize>,
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
    /// Steps taken in halves because they were not resolved (`subdivision.rs`).
    pub halved_steps: u64,
    /// Steps whose impacts were taken plastic because, with restitution, the contacts
    /// jammed (`moreau_jean::REACH`).
    pub plastic_steps: u64,
    /// Steps at whose end a body is past the middle of a part it sank into
    /// (`sinking.rs`), which a scheme that does not project does where h·v exceeds half
    /// the part's thickness.
    pub sank_through: u64,
    /// Steps (or parts of steps) that end with a journal squeezed across its ring
    /// (`squeezed.rs`): two points of one ring with opposing normals both pushing.
    pub squeezed_steps: u64,
    /// Steps the step-size control took again, smaller (`step_control.rs`); not counted
    /// in `steps`.
    pub rejected_steps: u64,
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

/// `Simulation::velocity_of`'s lists: the positions of the persistent and turning
/// contacts among the active ones, the turning ones' candidates, and the warm start.
#[derive(Default)]
pub(super) struct VelocityLists {
    persistent: Vec<usize>,
    turning: Vec<usize>,
    turning_candidates: Vec<Candidate>,
    warm: Vec<Vector3<f64>>,
}

/// `Simulation::project_poses`'s lists: the pool's candidates, the poses before the
/// projection, the poses last evaluated and the pool's points and clearance joints'
/// placements there.
#[derive(Default)]
pub(super) struct ProjectionLists {
    candidates: Vec<Candidate>,
    trial: Vec<Pose>,
    at: Vec<Pose>,
    points: Vec<ContactPoint>,
    placements: Placements,
}

/// Cloned where a run forks (`probe::run`): each copy then steps on its own, in a fresh
/// workspace.
#[derive(Clone)]
pub struct Simulation {
    pub model: Model,
    pub params: IntegrationParameters,
    /// The run's phases (settling, refinement window): the simulation's own, so that the
    /// fine branch of an extrapolated window can halve its window's step.
    pub schedule: Schedule,
    pub state: State,
    pub(super) candidates: Vec<Candidate>,
    /// Per candidate, the ring (2 × joint + side) of a clearance-joint guard
    /// (`ClearanceJoint::is_guard`); `None` for every other contact.
    pub(super) guard_ring: Vec<Option<usize>>,
    /// Per candidate, the ring whose closest point or guard it is (`squeezed.rs`).
    pub(super) ring_member: Vec<Option<usize>>,
    /// Per candidate, whether it loses its friction while the mechanism settles.
    pub(super) settle_frictionless: Vec<bool>,
    pub(super) mask: Vec<bool>,
    pub(super) minv: Vec<Matrix6<f64>>,
    pub(super) points: Vec<ContactPoint>,
    /// Whether the clearance guards' entries of `points` are their points at the current
    /// poses. Where not, each holds its current gap, and the rest of an earlier point of
    /// the same guard: a step reads the rest only where it may carry a journal across its
    /// clearance (`crossed_guards`), and evaluates the guards then
    /// (`evaluate_guards`). A guard that carries an impulse is always evaluated.
    pub(super) guards_evaluated: bool,
    /// Per candidate, its impulse over the last step (the sum of the step's parts, where it
    /// was taken in parts: `subdivision.rs`).
    pub(super) impulses: Vec<Vector3<f64>>,
    /// Per candidate, its impulse in the last velocity problem solved: the warm start of
    /// the next. Not the step's sum: two flanges pressing against each other in a jammed
    /// journal can carry any equal and opposite pair of impulses that the velocity problem
    /// does not see, and a warm start from a sum over parts would double that pair at every
    /// split step until its round-off gave the mechanism energy.
    pub(super) warm: Vec<Vector3<f64>>,
    pub(super) joint_impulses: Vec<f64>,
    /// Candidates in the velocity problem of the last step.
    pub(super) active: Vec<usize>,
    /// Size of the step being taken, or last taken: `params.h`, or the settle's step.
    pub(super) h: f64,
    /// Time and step count when the step size last changed: t = t0 + (steps − n0) h.
    pub(super) t0: f64,
    pub(super) n0: u64,
    /// The refinement window (`Schedule::refine`), its start and end, once its contact has
    /// closed.
    pub(super) refine_window: Option<(f64, f64)>,
    /// The instants at which a prescribed load bends in time (`Model::knots`): a step ends
    /// at each.
    knots: Vec<f64>,
    /// The poses at which every clearance joint's `check` last passed (a step's end): the
    /// next step starts from them and need not check them again.
    pub(super) checked_poses: Vec<Pose>,
    /// Per point of the compliant contacts (`Model::compliant_points`), the approach speed
    /// at which its present contact began; `None` while it is open.
    pub(super) compliant_onset: Vec<Option<f64>>,
    /// The compliant points at the current state with their forces (`update_compliant`).
    pub(super) compliant: Vec<(ContactPoint, Vector3<f64>)>,
    pub stats: RunStats,
    /// The first impact located within the last step, if one was.
    pub(super) located_impact: Option<LocatedImpact>,
    /// The storage the steps reuse (`workspace.rs`), boxed so that a step takes it and
    /// puts it back by moving a pointer.
    pub(super) workspace: Option<Box<StepWorkspace>>,
    /// The step-size controller, when `params.step_control` is set.
    pub(super) control: Option<Controller>,
}

impl Simulation {
    /// A simulation without phases (no settling, no refinement window).
    pub fn new(model: Model, params: IntegrationParameters) -> Result<Self, SimError> {
        Simulation::scheduled(model, params, Schedule::default())
    }

    /// A simulation with the phases of `schedule`.
    pub fn scheduled(
        model: Model,
        params: IntegrationParameters,
        schedule: Schedule,
    ) -> Result<Self, SimError> {
        params
            .validate()
            .map_err(|(f, m)| SimError::Parameters(f, m))?;
        let state = model.initial_state();
        let candidates = model.contact_candidates();
        let mask = model.dof_mask();
        let ring_member = super::squeezed::ring_members(&model, &candidates);
        let guard_ring: Vec<Option<usize>> = candidates
            .iter()
            .zip(&ring_member)
            .map(|(c, &ring)| match *c {
                Candidate::Clearance { joint, point }
                    if model.clearance_joints[joint].is_guard(point) =>
                {
                    ring
                }
                _ => None,
            })
            .collect();
        let settle_frictionless = candidates
            .iter()
            .map(|&c| schedule.frictionless_while_settling(&model, c))
            .collect();
        let control = params.step_control.as_ref().map(|_| {
            let radii = model
                .bodies
                .iter()
                .map(|b| b.radius_of_gyration())
                .collect();
            Controller::new(params.h, radii)
        });
        let mut sim = Simulation {
            ring_member,
            guard_ring,
            settle_frictionless,
            minv: inverse_mass(&model, &mask),
            mask,
            impulses: vec![Vector3::zeros(); candidates.len()],
            warm: vec![Vector3::zeros(); candidates.len()],
            joint_impulses: Vec::new(),
            active: Vec::new(),
            points: Vec::new(),
            guards_evaluated: false,
            candidates,
            h: params.h,
            t0: state.t,
            n0: 0,
            refine_window: None,
            knots: model.knots(),
            checked_poses: Vec::new(),
            compliant_onset: vec![None; model.compliant_points()],
            compliant: Vec::new(),
            model,
            params,
            schedule,
            state,
            stats: RunStats::default(),
            located_impact: None,
            workspace: None,
            control,
        };
        sim.update_geometry(None, None);
        sim.update_compliant(false);
        Ok(sim)
    }

    /// Contact points, penetration and joint violations at the current poses; `points` and
    /// `joints`, when given, are the contact points and the joints' violations already
    /// evaluated there (the combined scheme's activation test evaluates the points at the
    /// end-of-step poses, of the guards their gaps alone, and a projection the joints where
    /// it leaves them; violations of another time are evaluated again). Returns the points
    /// `points` replaced.
    pub(super) fn update_geometry(
        &mut self,
        points: Option<Vec<ContactPoint>>,
        joints: Option<JointViolation>,
    ) -> Option<Vec<ContactPoint>> {
        self.guards_evaluated = points.is_none() || self.model.clearance_joints.is_empty();
        let replaced = match points {
            Some(points) => Some(std::mem::replace(&mut self.points, points)),
            None => {
                self.model
                    .evaluate_selected(&self.state.poses, &self.candidates, &mut self.points);
                None
            }
        };
        for p in &self.points {
            self.stats.max_penetration = self.stats.max_penetration.max(-p.gap());
        }
        if !self.model.joints.is_empty() {
            let t = self.state.t;
            // rows that no drive moves are the same at any time: the projection's, at its
            // own rounding of the step's end, hold for them
            let timeless = self.model.joints.iter().all(|j| j.drive.is_none());
            let v = joints
                .filter(|v| v.t == t || timeless)
                .unwrap_or_else(|| JointViolation::at(&self.model, t, &self.state.poses));
            let s = &mut self.stats;
            s.max_joint_violation = s.max_joint_violation.max(v.length);
            s.max_joint_angle_violation = s.max_joint_angle_violation.max(v.angle);
        }
        replaced
    }

    pub(super) fn is_guard(&self, i: usize) -> bool {
        self.guard_ring[i].is_some()
    }

    /// Evaluates the clearance guards' points at the current poses, where `points` holds
    /// their gaps alone (`guards_evaluated`).
    pub(super) fn evaluate_guards(&mut self) {
        if !self.guards_evaluated {
            let (poses, candidates) = (&self.state.poses, &self.candidates);
            self.model
                .evaluate_guards(poses, candidates, &mut self.points);
            self.guards_evaluated = true;
        }
    }

    /// Contact candidates evaluated at the current state, in `Model::contact_candidates` order.
    /// Of a clearance guard that carries no impulse, only the gap is sure to be current
    /// (`ClearanceJoint::is_guard`): the combined scheme evaluates the rest of a guard's
    /// point only for a step that needs it.
    pub fn contact_points(&self) -> &[ContactPoint] {
        &self.points
    }

    /// What each contact point is (pair point or joint stop).
    pub fn contact_ids(&self) -> &[Candidate] {
        &self.candidates
    }

    /// The deepest overlap at the current state beyond what the scheme admits
    /// (`IntegrationParameters::admissible_depth`): what overlaps, named, and how deep (m).
    /// At t = 0 it is a modelling error that a run's later failure would only show as a
    /// symptom (a journal thrown out of its bore).
    pub fn deepest_overlap(&self) -> Option<(String, f64)> {
        let (i, depth) = (0..self.points.len())
            .filter(|&i| !self.is_guard(i))
            .map(|i| (i, -self.points[i].gap()))
            .max_by(|a, b| a.1.total_cmp(&b.1))?;
        if depth <= self.params.admissible_depth() {
            return None;
        }
        let candidate = self.candidates[i];
        let name = self.model.candidate_name(candidate);
        let body = |b: crate::mechanics::BodyRef| {
            b.map_or("ground".to_string(), |b| self.model.bodies[b].name.clone())
        };
        let what = match candidate {
            Candidate::Pair { pair, .. } => {
                let p = &self.model.contacts[pair];
                format!(
                    "`{}` and `{}`, contact `{name}`",
                    body(p.body1),
                    body(p.body2)
                )
            }
            Candidate::Clearance { joint, .. } => {
                let j = &self.model.clearance_joints[joint];
                let (a, b) = (body(j.bore_body), body(j.journal_body));
                format!("journal `{b}` and bore `{a}`, clearance joint point `{name}`")
            }
            Candidate::Limit { .. } => format!("a joint past its limit `{name}`"),
        };
        Some((what, depth))
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

    /// The first impact located within the last step (`locate_impacts`), if one was.
    pub fn located_impact(&self) -> Option<&LocatedImpact> {
        self.located_impact.as_ref()
    }

    /// The end of the refinement window, once it has opened.
    pub fn refine_window_end(&self) -> Option<f64> {
        self.refine_window.map(|(_, end)| end)
    }

    /// The refinement window's start and end, once it has opened.
    pub fn refine_window(&self) -> Option<(f64, f64)> {
        self.refine_window
    }

    /// Closes the refinement window now, if it is open: its event (`Refine::until`) has
    /// happened. It does not open again.
    pub fn close_refine_window(&mut self) {
        let now = self.state.t;
        if let Some((_, end)) = self.refine_window.as_mut() {
            *end = end.min(now);
        }
    }

    /// The step that starts now, and the time it ends at when that is a phase's end: the
    /// settle's step while settling, the refinement window's within it, each phase's last
    /// step shortened or stretched (by at most 1e-9) to end at the phase's end; else h.
    ///
    /// Under step control, the controller's step, cut to end at the settle's end; the
    /// refinement window, a fixed refinement of the step, does not apply.
    ///
    /// Either way a step ends at the next knot of the loads in time (`Model::knots`).
    #[inline]
    pub(super) fn next_step(&self) -> (f64, Option<f64>) {
        let (h, ends_at) = self.phase_step();
        // a knot of the loads in time ends the step at it; one within 1e-9 h of the step's
        // start counts as passed
        let t = self.state.t;
        let next = self.knots.partition_point(|&k| k <= t + 1e-9 * h);
        match self.knots.get(next) {
            Some(&knot) if knot - t < h * (1.0 - 1e-9) => (knot - t, Some(knot)),
            _ => (h, ends_at),
        }
    }

    /// The step that starts now by the run's phases alone (`next_step`).
    #[inline]
    fn phase_step(&self) -> (f64, Option<f64>) {
        let t = self.state.t;
        let settle = self.schedule.settling(t);
        if let Some(c) = &self.control {
            let h = c.proposal;
            return match settle {
                Some(s) if s.until - t <= h * (1.0 + 1e-9) => (s.until - t, Some(s.until)),
                _ => (h, None),
            };
        }
        let window = self
            .refine_window_end()
            .zip(self.schedule.refine.as_ref())
            .map(|(until, r)| (until, r.step_ratio * self.params.h))
            .filter(|&(until, h)| t < until - 1e-9 * h);
        // after the settle and before the window opens, its approach step, if it has one
        let approach = match (settle, &self.schedule.refine, self.refine_window) {
            (None, Some(r), None) => r.approach_ratio.map(|a| (f64::INFINITY, a * self.params.h)),
            _ => None,
        };
        match settle
            .and_then(|s| s.step_ratio.map(|r| (s.until, r * self.params.h)))
            .or(window)
            .or(approach)
        {
            Some((until, h)) if until - t <= h * (1.0 + 1e-9) => (until - t, Some(until)),
            Some((_, h)) => (h, None),
            None => (self.params.h, None),
        }
    }

    /// The integration parameters of the current step (h may be the settle's, and so may
    /// the solver's tolerance).
    pub(super) fn step_params(&self) -> IntegrationParameters {
        let mut p = IntegrationParameters {
            h: self.h,
            ..self.params.clone()
        };
        if let Some(r) = self
            .schedule
            .settling(self.state.t)
            .and_then(|s| s.tolerance_ratio)
        {
            p.solver.tolerance *= r;
        }
        p
    }

    /// The velocity step with the contacts `active`, but for those that face another one
    /// which the step's motion closes first (`opposed.rs`): they take no impulse.
    pub(super) fn velocity(&self, active: &[usize], ws: &mut VelocityWorkspace) -> VelocityStep {
        let Some(dropped) = self.behind_opposed(active, &mut ws.facing) else {
            return self.velocity_of(active, ws);
        };
        let kept: Vec<usize> = active
            .iter()
            .zip(&dropped)
            .filter(|(_, &d)| !d)
            .map(|(&i, _)| i)
            .collect();
        let mut vs = self.velocity_of(&kept, ws);
        let (mut impulses, mut speeds) = (vs.impulses.into_iter(), vs.normal_speeds.into_iter());
        let v = vs.v.as_slice();
        (vs.impulses, vs.normal_speeds) = active
            .iter()
            .zip(&dropped)
            .map(|(&i, &d)| match d {
                true => (Vector3::zeros(), self.points[i].normal_velocity(v)),
                false => (
                    impulses.next().expect("one per kept"),
                    speeds.next().expect("one per kept"),
                ),
            })
            .unzip();
        vs
    }

    /// The velocity step with exactly the contacts `active`.
    fn velocity_of(&self, active: &[usize], ws: &mut VelocityWorkspace) -> VelocityStep {
        let joints = &self.model.joints;
        let rows_at = |t: f64, poses: &[Pose], out: &mut Vec<BilateralRow>| {
            self.model.joint_rows_into(t, poses, out)
        };
        let rows_at = (!joints.is_empty()).then_some(&rows_at as JointRowsAt);
        let params = self.step_params();
        let start = StepStart {
            model: &self.model,
            mask: &self.mask,
            params: &params,
            damping: self.schedule.settle_damping(self.state.t),
            t: self.state.t,
            poses: &self.state.poses,
            v0: &self.state.v,
            onset: &self.compliant_onset,
        };
        if active.is_empty() {
            return velocity_step(&start, &[], &[], None, rows_at, &mut ws.step);
        }
        let contacts = self.active_contacts(active);
        self.persistent_contacts(active, &mut ws.lists);
        let VelocityLists {
            persistent,
            turning,
            turning_candidates,
            warm,
        } = &ws.lists;
        let at = |poses: &[Pose], out: &mut Vec<ContactPoint>| {
            self.model.evaluate_selected(poses, turning_candidates, out);
            for (c, &k) in out.iter_mut().zip(turning.iter()) {
                c.mu = contacts[k].mu;
            }
        };
        let active_at = ActiveAt {
            persistent,
            turning,
            at: &at,
        };
        velocity_step(
            &start,
            &contacts,
            warm,
            Some(&active_at),
            rows_at,
            &mut ws.step,
        )
    }

    /// Whether contact `i` is closed: pressed in the last step, or in its velocity problem
    /// and still touching (as the unloaded twin of a pressed ring is). Guards never are.
    fn closed(&self, i: usize) -> bool {
        !self.is_guard(i)
            && (self.impulses[i].x > 0.0
                || (self.active.contains(&i)
                    && self.points[i].gap() <= self.params.activation_margin))
    }

    /// The contacts `active` with the coefficients they have in this step.
    ///
    /// The contacts enter with their coefficients, but while settling those that lose
    /// their friction with μ = 0; and, where positions are projected, those closed in the
    /// last step and approaching with e = 0. A closed contact has no impact to restitute:
    /// what its start-of-step rows show as approach is the turn of its frame over the last
    /// step (a journal sliding around its bore), and restitution on it would push the
    /// journal off the wall at every step, giving the mechanism energy at coarse steps. A
    /// resting contact struck through another one has no approach at the step's start, so
    /// e changes nothing there.
    fn active_contacts(&self, active: &[usize]) -> Vec<ActiveContact<'_>> {
        let settling = self.schedule.settling(self.state.t).is_some();
        let projected = self.params.scheme.projects();
        active
            .iter()
            .map(|&i| {
                let mut c = ActiveContact::of(&self.points[i]);
                if settling && self.settle_frictionless[i] {
                    c.mu = 0.0;
                }
                let approaching = || c.point.normal_velocity(self.state.v.as_slice()) < 0.0;
                if projected && self.closed(i) && approaching() {
                    c.e = 0.0;
                }
                c
            })
            .collect()
    }

    /// Into `lists`: the positions among `active` of the closed contacts (persistent), of
    /// those whose normal row can turn, their candidates, and the warm start.
    ///
    /// The closed contacts also act along their rows at mid-step and meet their velocity
    /// condition along those at the step's end (`ActiveAt`). On start-of-step rows a
    /// journal sliding around its bore drifts into the wall. Without a projection nothing
    /// would take it out. With one, the projection would lift the journal back at every
    /// step, which is work done on the mechanism and an error of first order in h (in the
    /// energy of a swinging clearance pendulum, in the mean load on a cam rocker's
    /// sliding pivot).
    fn persistent_contacts(&self, active: &[usize], lists: &mut VelocityLists) {
        let VelocityLists {
            persistent,
            turning,
            turning_candidates,
            warm,
        } = lists;
        // a body turning by more than ROW_TURN in the step turns the lever to a point it
        // slides along a fixed plane with
        let turns = |b: usize| self.h * self.state.v.fixed_rows::<3>(6 * b + 3).norm() > ROW_TURN;
        persistent.clear();
        persistent.extend(
            (0..active.len())
                .filter(|&k| self.closed(active[k]) && !self.points[active[k]].gap_law),
        );
        turning.clear();
        turning.extend(
            persistent
                .iter()
                .copied()
                .filter(|&k| match self.candidates[active[k]] {
                    Candidate::Pair { pair, .. } => {
                        let c = &self.model.contacts[pair];
                        !c.normal_is_fixed(&self.mask) || c.body1.is_some_and(turns)
                    }
                    _ => true,
                }),
        );
        turning_candidates.clear();
        turning_candidates.extend(turning.iter().map(|&k| self.candidates[active[k]]));
        // a guard's index names a point relative to the current closest point, so its last
        // impulse belongs to another point: start it cold
        warm.clear();
        warm.extend(active.iter().map(|&i| {
            if self.is_guard(i) {
                Vector3::zeros()
            } else {
                self.warm[i]
            }
        }));
    }

    /// Projects `poses` at t + h: joints, plus those of the candidates `pool` (ascending
    /// indices) that `which` chooses, given their contact points at those poses, with the
    /// chord steps of the step's joint elimination `chord` (`project`). Also returns the
    /// pool's points and their clearance joints' placements at the poses it leaves, when
    /// it evaluated them there (a projection that finds the poses admissible leaves them as
    /// they are).
    pub(super) fn project_poses<'w>(
        &self,
        poses: &mut [Pose],
        pool: &[usize],
        which: &dyn Fn(usize, &ContactPoint) -> bool,
        mode: ContactRows,
        chord: Option<&mut Elimination>,
        ws: &'w mut ProjectionWorkspace,
    ) -> (
        ProjectionOutcome,
        Option<(&'w [ContactPoint], &'w Placements)>,
    ) {
        let model = &self.model;
        // chord steps are for joints alone: a pool of contacts may have some projected, and
        // a projection that may need Gauss–Newton starts from the rows' gradients
        let mut chord = chord
            .filter(|_| pool.is_empty())
            .map(|e| |rows: &[BilateralRow], dnu: &mut DVector<f64>| e.chord_step(rows, dnu));
        if model.joints.is_empty() && pool.is_empty() {
            // nothing to project: what `project` reports for no rows
            let outcome = ProjectionOutcome {
                converged: true,
                ..Default::default()
            };
            return (outcome, None);
        }
        let ProjectionWorkspace {
            lists,
            project: storage,
        } = ws;
        let ProjectionLists {
            candidates,
            trial,
            at,
            points,
            placements,
        } = lists;
        candidates.clear();
        candidates.extend(pool.iter().map(|&i| self.candidates[i]));
        let candidates = &*candidates;
        // the poses last evaluated and the pool's points and placements there
        let last = RefCell::new((at, points, placements));
        let contacts = |ps: &[Pose], rows: &mut ContactRowsOf| {
            let mut last = last.borrow_mut();
            let (at, pts, placements) = &mut *last;
            let (at, pts) = (&mut **at, &mut **pts);
            at.clear();
            at.extend_from_slice(ps);
            model.evaluate_selected_keeping(ps, candidates, placements, pts);
            rows.reserve(pts.len());
            for (&i, cp) in pool.iter().zip(pts.iter()) {
                if which(i, cp) {
                    rows.add(cp);
                }
            }
        };
        trial.clear();
        trial.extend_from_slice(poses);
        let mut outcome = project(
            model,
            &self.mask,
            &self.minv,
            self.state.t + self.h,
            poses,
            &contacts,
            mode,
            self.params.projection_tolerance,
            self.params.projection_max_iterations,
            chord.as_mut().map(|c| -> ChordStep { c }),
            storage,
        );
        // (a projection that took no iteration left the trial)
        if outcome.iterations > 0 && self.landed_farther(trial, poses) {
            outcome.converged = false;
        }
        let (last_at, pts, placements) = last.into_inner();
        let evaluated = (last_at.as_slice() == &*poses).then_some((&pts[..], &*placements));
        (outcome, evaluated)
    }

    /// Whether a projection from the poses `trial` to `projected` found another solution
    /// of its equations than the nearest one, which makes the step one to take in halves.
    ///
    /// Where the start of the step is admissible, the nearest admissible poses are no
    /// farther from the trial than it is. A projection that lands farther has found
    /// another solution (a journal jammed between its flanges at a coarse step, thrown many
    /// times the step's own motion).
    fn landed_farther(&self, trial: &[Pose], projected: &[Pose]) -> bool {
        let depth = self.params.admissible_depth();
        let admissible =
            (0..self.points.len()).all(|i| self.is_guard(i) || self.points[i].gap() >= -depth);
        let slack = mass_distance_of_length(&self.model, self.params.projection_tolerance);
        admissible && !within_reach(&self.model, trial, projected, &self.state.poses, slack)
    }

    /// Advances one step of size h (the settle's step while settling), in parts where it
    /// must be (`subdivision.rs`): halved where it is not resolved, split at an impact with
    /// `locate_impacts` or where one impact knocks another contact shut.
    pub fn step(&mut self) -> Result<StepReport, SimError> {
        self.step_until(f64::INFINITY)
    }

    /// `step`, its length cut where it would pass `t_end` (a run's end, which need not be
    /// a multiple of h).
    pub fn step_until(&mut self, t_end: f64) -> Result<StepReport, SimError> {
        if self.control.is_some() {
            return self.controlled_step(t_end);
        }
        let step_end = self.sized_step(t_end);
        let report = self.advance_whole(step_end)?;
        Ok(self.conclude(report))
    }

    /// Sets the next step's size (`self.h`), cut to end at `t_end`; returns the time it
    /// ends at.
    fn sized_step(&mut self, t_end: f64) -> f64 {
        let (mut h, mut ends_at) = self.next_step();
        if t_end - self.state.t < h * (1.0 - 1e-9) {
            (h, ends_at) = (t_end - self.state.t, Some(t_end));
        }
        if h != self.h {
            self.h = h;
            self.t0 = self.state.t;
            self.n0 = self.stats.steps;
        }
        ends_at.unwrap_or(self.t0 + (self.stats.steps + 1 - self.n0) as f64 * h)
    }

    /// The step of size `self.h` to `step_end`, in parts where it must be.
    fn advance_whole(&mut self, step_end: f64) -> Result<StepReport, SimError> {
        let mut ws = self.workspace.take().unwrap_or_default();
        self.located_impact = None;
        let report = self.advance(step_end, Depth::default(), &mut ws);
        self.workspace = Some(ws);
        // a guard's impulse acts along its point's rows (a probe's reaction)
        let pushed = |(ring, p): (&Option<usize>, &Vector3<f64>)| ring.is_some() && p.x != 0.0;
        if !self.guards_evaluated && self.guard_ring.iter().zip(&self.impulses).any(pushed) {
            self.evaluate_guards();
        }
        report
    }

    /// `step_until` under step control: the controller's step, taken again smaller until
    /// the controller accepts it (`step_control.rs`).
    fn controlled_step(&mut self, t_end: f64) -> Result<StepReport, SimError> {
        let c = self.params.step_control.clone().expect("controlled");
        loop {
            let proposal = self.control.as_ref().expect("controlled").proposal;
            let step_end = self.sized_step(t_end);
            let h_tried = self.h;
            let before = Rollback::of(self);
            let h_new = match self.advance_whole(step_end) {
                Ok(report) => match self.judge_step(&c, &before, proposal) {
                    Verdict::Accept => return Ok(self.conclude(report)),
                    Verdict::Retry(h_new) => h_new,
                },
                // a step that fails even in halves may pass smaller
                Err(SimError::Geometry { .. } | SimError::NonFinite { .. })
                    if h_tried > c.h_min * (1.0 + 1e-9) =>
                {
                    (SHRINK_MAX * h_tried).max(c.h_min)
                }
                Err(e) => return Err(e),
            };
            before.restore(self);
            self.stats.rejected_steps += 1;
            self.control.as_mut().expect("controlled").proposal = h_new;
        }
    }

    /// The controller's verdict on the step just taken from the state `before`, whose
    /// proposed size was `proposal`.
    fn judge_step(&mut self, c: &StepControl, before: &Rollback, proposal: f64) -> Verdict {
        // the step taken: shorter than tried where it ended at an impact
        let h = self.state.t - before.time();
        let closed = (0..self.impulses.len())
            .any(|i| self.impulses[i].x > 0.0 && before.impulses()[i].x <= 0.0);
        // how deep the step carried a body into a contact that was open at its start
        let overshoot = (0..self.points.len())
            .filter(|&i| !self.is_guard(i) && before.points()[i].gap() > 0.0)
            .map(|i| -self.points[i].gap())
            .fold(0.0, f64::max);
        let taken = Taken {
            h,
            v0: before.velocities(),
            v1: &self.state.v,
            closed,
            constrained: self.impulses.iter().any(|p| p.x > 0.0)
                || self.joint_impulses.iter().any(|&p| p != 0.0),
            overshoot,
            located: self.stats.impact_splits > before.stats().impact_splits,
            clipped: h < proposal * (1.0 - 1e-9),
        };
        self.control.as_mut().expect("controlled").judge(c, &taken)
    }

    /// Counts a step just taken in the run's diagnostics, and opens the refinement window
    /// where its contact closed (but under step control).
    fn conclude(&mut self, report: StepReport) -> StepReport {
        self.stats.steps += 1;
        // the refinement window opens at the end of the step in which its contact closed
        // (a controlled run refines its steps itself)
        let refined = self.control.is_none();
        if let (None, Some(r), true) = (self.refine_window, &self.schedule.refine, refined) {
            if r.trigger.iter().any(|&i| self.impulses[i].x > 0.0) {
                self.refine_window = Some((self.state.t, self.state.t + r.duration));
            }
        }
        let s = &mut self.stats;
        s.solver_failures += u64::from(!report.solver.converged);
        s.newton_failures += u64::from(!report.newton_converged);
        s.plastic_steps += u64::from(report.plastic);
        let projected = self.params.scheme.projects();
        s.projection_failures += u64::from(projected && !report.projection.converged);
        s.max_solver_residual = s.max_solver_residual.max(report.solver.residual);
        s.max_active_contacts = s.max_active_contacts.max(report.active_contacts);
        s.max_active_set_passes = s.max_active_set_passes.max(report.active_set_passes);
        s.max_projection_iterations = s
            .max_projection_iterations
            .max(report.projection.iterations);
        report
    }

    /// The step of size `self.h` from the current state, not yet taken.
    /// The combined scheme evaluates the clearance guards' points first where the step
    /// needs them and the state holds their gaps alone (`guards_evaluated`).
    pub(super) fn compute(&mut self, ws: &mut StepWorkspace) -> Result<Outcome, SimError> {
        let p = self.step_params();
        // poses a step ended at were checked when that step was computed
        let joints = &self.model.clearance_joints;
        if !joints.is_empty() && self.state.poses != self.checked_poses {
            for j in joints {
                j.check(&self.state.poses)
                    .map_err(|message| SimError::Geometry {
                        t: self.state.t,
                        message,
                    })?;
            }
        }
        let mut report = StepReport::default();
        let mut outcome = match p.scheme {
            Scheme::MoreauJean | Scheme::DirectProjection => {
                let v0 = &self.state.v;
                let forecast =
                    |c: &ContactPoint| p.forecast(c, v0.as_slice()) <= p.activation_margin;
                let mut in_active: Vec<bool> = self.points.iter().map(forecast).collect();
                let mut active: Vec<usize> =
                    (0..in_active.len()).filter(|&i| in_active[i]).collect();
                let mut vs = self.velocity(&active, &mut ws.velocity);
                report.active_set_passes = 1;
                // a contact the step jumps across joins, and the step is taken again
                let mut crossed = Vec::new();
                while report.active_set_passes < p.max_active_set_passes {
                    self.jumped_across(&in_active, &vs, &mut crossed);
                    if crossed.is_empty() {
                        break;
                    }
                    crossed.iter().for_each(|c| in_active[c.0] = true);
                    active = (0..in_active.len()).filter(|&i| in_active[i]).collect();
                    ws.velocity.step.keep_spent(vs);
                    vs = self.velocity(&active, &mut ws.velocity);
                    report.active_set_passes += 1;
                }
                let mut poses = ws.velocity.step.copy_poses(&vs.poses);
                if p.scheme == Scheme::DirectProjection {
                    let chord = vs.elimination.as_deref_mut();
                    report.projection = self
                        .project_poses(
                            &mut poses,
                            &active,
                            &|_, _| true,
                            ContactRows::Inequality,
                            chord,
                            &mut ws.projection,
                        )
                        .0;
                }
                Outcome {
                    active,
                    vs,
                    poses,
                    points: None,
                    closing: Vec::new(),
                    sinking: Vec::new(),
                    report,
                }
            }
            // once the guards are evaluated, the step needs nothing more
            Scheme::CombinedProjection => loop {
                if let Some(outcome) = self.combined(report, ws) {
                    break outcome;
                }
                self.evaluate_guards();
            },
        };
        if outcome.vs.v.as_slice().iter().any(|x| !x.is_finite())
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
        outcome.sinking = self.sinking(&outcome.vs.v);
        Ok(outcome)
    }

    /// Takes the computed step: the state at time `t`, its impulses and contact points.
    /// What the step leaves of its storage goes back to `ws`.
    pub(super) fn commit(
        &mut self,
        outcome: Outcome,
        t: f64,
        ws: &mut StepWorkspace,
    ) -> StepReport {
        let Outcome {
            active,
            mut vs,
            poses,
            points,
            sinking,
            mut report,
            ..
        } = outcome;
        self.record_contacts(&active, &vs);
        ws.velocity.step.keep_elimination(vs.elimination.take());
        std::mem::swap(&mut self.joint_impulses, &mut vs.joint_impulses);
        self.active = active;
        std::mem::swap(&mut self.state.v, &mut vs.v);
        let left = std::mem::replace(&mut self.state.poses, poses);
        ws.velocity.step.keep_poses(left);
        self.state.t = t;
        // `compute` checked the poses of every outcome it returned
        if !self.model.clearance_joints.is_empty() {
            self.checked_poses.clone_from(&self.state.poses);
        }
        let replaced = self.update_geometry(points, report.projection.joint_violation);
        ws.activation.keep_points(replaced);
        self.update_compliant(true);
        self.stats.sank_through += u64::from(self.sank_past(&sinking, &self.points));
        report.active_contacts = self.active.len();
        report.newton_iterations = vs.newton_iterations;
        report.newton_converged = vs.newton_converged;
        report.solver = vs.solver;
        report.plastic = vs.plastic;
        ws.velocity.step.keep_spent(vs);
        report
    }

    /// The compliant points at the current state, each with its force (`compliant_points`);
    /// at a step's end (`step_end`), each point's closing speed first: kept while it stays
    /// closed, its approach speed now where it has just closed (the speed its force took
    /// while it closed), none where it is open.
    fn update_compliant(&mut self, step_end: bool) {
        let (poses, v) = (&self.state.poses, self.state.v.as_slice());
        self.compliant.clear();
        for (c, span) in self.model.compliant_spans() {
            let law = c.point_law();
            for (k, i) in span.enumerate() {
                let point = c.evaluate(k, poses);
                let onset = &mut self.compliant_onset[i];
                if step_end {
                    *onset = match (point.gap() < 0.0, *onset) {
                        (false, _) => None,
                        (true, Some(o)) => Some(o),
                        (true, None) => Some((-point.normal_velocity(v)).max(0.0)),
                    };
                }
                let force = law.local_force(&point, v, *onset);
                self.compliant.push((point, force));
            }
        }
    }

    /// The compliant contacts' points at the current state, over all of them in order,
    /// each with its force on body 1 in its local frame (n, t1, t2).
    pub fn compliant_points(&self) -> &[(ContactPoint, Vector3<f64>)] {
        &self.compliant
    }

    /// The impulses of the contacts `active` over a step; every other contact has none.
    pub(super) fn record_contacts(&mut self, active: &[usize], vs: &VelocityStep) {
        self.impulses.iter_mut().for_each(|x| *x = Vector3::zeros());
        for (&i, imp) in active.iter().zip(&vs.impulses) {
            self.impulses[i] = *imp;
        }
        // an impact (a step of length 0) is no start for a step of finite length
        if self.h > 0.0 {
            self.warm.clone_from(&self.impulses);
        }
    }

    /// Whether a run to `t_end` is over: `t_end` is nearer than 1e-9 of the next step.
    pub fn reached(&self, t_end: f64) -> bool {
        self.state.t >= t_end - 1e-9 * self.next_step().0
    }

    /// Steps until `t_end`, the last step cut to end there, calling `observe` after every
    /// step.
    pub fn run_until(
        &mut self,
        t_end: f64,
        mut observe: impl FnMut(&Simulation, &StepReport),
    ) -> Result<(), SimError> {
        while !self.reached(t_end) {
            let r = self.step_until(t_end)?;
            observe(self, &r);
        }
        Ok(())
    }
}
