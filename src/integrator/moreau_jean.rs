//! One velocity-level step of the Moreau–Jean θ-scheme (docs/method.md, "One step"):
//!
//! M (v₁ − v₀) − h[θ F(t₁, q₁, v₁) + (1 − θ) F(t₀, q₀, v₀)] = Σ_α G_αᵀ P_α,
//! q₁ = q₀ ⊕ h v_θ, with the active contacts' impulses from FC3D on the shifted local
//! velocity U_N,₁ + e U_N,₀ (Newton impact law). A Newton loop handles nonlinear forces.
//! A contact that closes within the step has its rows frozen at q₀ (so that an impact
//! with e = 1 keeps the kinetic energy exactly); one that was already closed is treated
//! as the joints are (`ActiveAt`).

use super::elimination::Elimination;
use super::iteration_matrix::IterationMatrix;
use super::params::IntegrationParameters;
use crate::math::blocks::vector3;
use crate::math::buffer::{self, copy_into, zeros};
use crate::mechanics::body::{moves, Twist};
use crate::mechanics::joint::BilateralRow;
use crate::mechanics::{ContactPoint, Model, Pose};
use crate::solver::{solve_fc3d, Fc3d, NsgsOptions, SolverStatus, SolverStorage};
use nalgebra::{ArrayStorage, DMatrix, DVector, Matrix3x6, Matrix6x3, Vector3};

/// The joints' bilateral rows evaluated at a time and poses, appended to a list.
pub type JointRowsAt<'a> = &'a dyn Fn(f64, &[Pose], &mut Vec<BilateralRow>);

/// The turning contacts (`ActiveAt::turning`) evaluated at other poses, in order, written
/// over the entries of a list.
pub type ContactsAt<'a> = &'a dyn Fn(&[Pose], &mut Vec<ContactPoint>);

/// The active contacts evaluated at other poses, and those of them that were closed when
/// the step began (persistent). Like the joints' rows (`Elimination`), a persistent
/// contact's impulse acts along its rows at the step's midpoint and its velocity is
/// measured at the step's end: a contact sliding along a concave surface, or carried on a
/// long lever by a turning body, then drifts off its surface by O(h³) per step instead of
/// O(h²), and steady sliding along a circle does no work. The Delassus matrix is then not
/// symmetric, which slows the solver. A contact that closes within the step keeps the rows
/// it is given: the same rows then measure its impulse and both velocities of Newton's law,
/// which is what makes an impact with e = 1 keep the kinetic energy and one with e < 1 lose
/// it, at any step.
pub struct ActiveAt<'a> {
    /// Positions of the persistent contacts among the active ones, ascending.
    pub persistent: &'a [usize],
    /// Those of them whose normal row can turn over a step, the ones evaluated at mid-step
    /// and at the end: a contact on a plane that cannot turn, of a body that does not turn
    /// either, keeps its start rows without being evaluated to find that out, as any
    /// contact whose normal row does not turn does.
    pub turning: &'a [usize],
    /// The turning contacts evaluated at the given poses.
    pub at: ContactsAt<'a>,
}

/// A contact of the velocity problem: its point, with the friction and restitution
/// coefficients it has in this step (a settling step may take its friction away, a
/// projecting scheme the restitution of a closed contact).
#[derive(Clone, Copy, Debug)]
pub struct ActiveContact<'a> {
    pub point: &'a ContactPoint,
    pub mu: f64,
    pub e: f64,
}

impl<'a> ActiveContact<'a> {
    /// The point with its own coefficients.
    pub fn of(point: &'a ContactPoint) -> Self {
        ActiveContact {
            point,
            mu: point.mu,
            e: point.e,
        }
    }
}

/// Result of the velocity step.
pub struct VelocityStep {
    pub v: DVector<f64>,
    /// The poses at the step's end, q₁ = q₀ ⊕ h((1 − θ) v₀ + θ v₁): the last Newton
    /// iterate placed them there to test its residual.
    pub poses: Vec<Pose>,
    /// Impulse (P_N, P_T1, P_T2) of each active contact, in its local frame.
    pub impulses: Vec<Vector3<f64>>,
    /// Each active contact's normal velocity u_N,k+1 at the step's end, measured along the
    /// rows its velocity condition was imposed on: the end rows of a persistent contact
    /// whose normal row turns, the start rows of any other.
    pub normal_speeds: Vec<f64>,
    pub newton_iterations: usize,
    pub newton_converged: bool,
    /// Impulse of each bilateral row (joint reactions over the step).
    pub joint_impulses: Vec<f64>,
    /// The joints' elimination the step ended with, factorised (`None` without joints):
    /// the step's projection takes its first steps with it (`Elimination::chord_step`),
    /// and `VelocityStorage::keep_elimination` keeps it for the next step's.
    pub(super) elimination: Option<Box<Elimination>>,
    /// Status of the last FC3D solve (the one whose impulses are applied).
    pub solver: SolverStatus,
    /// Its impacts were taken plastic (e = 0): with restitution, the contacts jammed.
    pub plastic: bool,
}

/// Poses at the end of the step, q₁ = q₀ ⊕ h((1 − θ) v₀ + θ v₁), into `out`, whose
/// allocation the Newton iterations reuse.
pub(super) fn advance_poses_into(
    out: &mut Vec<Pose>,
    poses: &[Pose],
    v0: &DVector<f64>,
    v1: &DVector<f64>,
    h: f64,
    theta: f64,
) {
    out.clear();
    out.extend(poses.iter().enumerate().map(|(i, p)| {
        let a = v0.fixed_rows::<6>(6 * i);
        let b = v1.fixed_rows::<6>(6 * i);
        let delta: Twist = (a * (1.0 - theta) + b * theta) * h;
        p.advanced(&delta)
    }));
}

/// A persistent contact whose normal row turns by more than this (rad) over its step
/// (`ContactPoint::row_turn`: its normal, or the lever from a body's centre to the point,
/// as on a body that turns while its point slides along a fixed face) acts on its midpoint
/// rows and meets its velocity condition on its end rows. Below, the start rows differ
/// from those by less than the solver's tolerance.
pub(super) const ROW_TURN: f64 = 1e-6;

/// Under a projection, a persistent contact whose normal row turns by more than this over
/// its step (a chord of 0.2, 11.5°) keeps its start rows: its rows at mid-step and at the end
/// are then those of other points, not of one point sliding along its surface, which is
/// what they stand for, and the projection removes the drift that start rows leave. A
/// journal that one step throws across its bore is such a contact: the circuit breaker
/// with frictionless clearances of 1 nm, which must behave as the ideal mechanism, keeps
/// its opening time within a few 1e-4 of the ideal one at this bound, and drifts with the
/// step size at larger ones. Plain Moreau–Jean, which nothing takes out of a wall, keeps
/// these rows at any turn.
const SWUNG: f64 = 0.2;

/// Sweeps allowed a nonsymmetric contact problem (mid-step and end rows), with the global
/// Newton method they try on the way but without the last resort, before the step falls
/// back to its start-of-step rows. Gauss–Seidel needs symmetry to converge surely, and
/// the last resort's proximal iterations can take seconds to fail on such a problem; the
/// circuit breaker's nominal nonsymmetric problems take a few tens of sweeps and Newton
/// iterations at most.
const NONSYMMETRIC_SWEEPS: usize = 40;

/// A contact's Jacobian blocks on its moving bodies: at most two, kept inline (a step
/// builds them for every active contact).
#[derive(Clone, Copy)]
struct ContactBlocks {
    blocks: [(usize, Matrix3x6<f64>); 2],
    len: usize,
}

impl std::ops::Deref for ContactBlocks {
    type Target = [(usize, Matrix3x6<f64>)];
    fn deref(&self) -> &Self::Target {
        &self.blocks[..self.len]
    }
}

impl ContactBlocks {
    /// No blocks: a list's entry before it is written.
    const EMPTY: ContactBlocks = ContactBlocks {
        blocks: [(
            0,
            Matrix3x6::from_array_storage(ArrayStorage([[0.0; 3]; 6])),
        ); 2],
        len: 0,
    };

    /// The blocks of contact `c` on its moving bodies (`mask`), written over these where
    /// they lie: blocks of 304 bytes built aside and copied into a list are read back in
    /// pieces that straddle those they were stored in, and the copy waits for the stores.
    fn write(&mut self, c: &ContactPoint, mask: &[bool]) {
        self.len = 0;
        for (side, body) in [c.body1, c.body2].into_iter().enumerate() {
            if let Some(b) = body.filter(|&b| moves(mask, b)) {
                self.blocks[self.len] = (b, c.block(side));
                self.len += 1;
            }
        }
    }

    /// The local velocity (u_N, u_T1, u_T2) these rows measure for the twists `v`.
    fn velocity(&self, v: &DVector<f64>) -> Vector3<f64> {
        let mut u = Vector3::zeros();
        for (b, g) in self.iter() {
            u += g * v.fixed_rows::<6>(6 * b);
        }
        u
    }
}

/// Where a velocity step starts: the model and its integrated degrees of freedom
/// (`mask`, `model.dof_mask()`), the step's parameters, the settling damping in force, and
/// the state (t, poses, v0).
pub struct StepStart<'a> {
    pub model: &'a Model,
    pub mask: &'a [bool],
    pub params: &'a IntegrationParameters,
    /// α of the settling phase's damping −α M v in this step (0 outside it).
    pub damping: f64,
    pub t: f64,
    pub poses: &'a [Pose],
    pub v0: &'a DVector<f64>,
    /// The compliant contacts' closing speeds (`Model::wrench`).
    pub onset: &'a [Option<f64>],
}

/// Velocity step from (t, poses, v0) with the contacts `active` (evaluated at `poses`),
/// warm-started from `warm` (one impulse per active contact), with the persistent ones
/// of `contacts` at mid-step and end rows, and the bilateral rows of the joints,
/// `joints(q̄)` (rates b at t + h/2). The joints are imposed at the midpoint,
/// H(q_{k+½}) (v_k + v_{k+1})/2 = b, with q_{k+½} from the current Newton iterate: this
/// keeps the θ = 1/2 scheme second order on constrained motion, where frozen
/// start-of-step rows H(q_k) v_{k+1} = b are only first order (measured on the pendulum:
/// order 2.00 vs 1.00, 230× smaller error at h = 1 ms). The position drift left is
/// O(h³) per step and the projection removes it.
///
/// The Delassus matrix is assembled block by block from the sparse contact Jacobians.
/// With joints the equality rows are eliminated exactly (Schur complement, `Elimination`)
/// and the contacts see the constrained operator W⁻¹ − W⁻¹Hᵀ(HW⁻¹Hᵀ)⁻¹HW⁻¹, which differs
/// from W⁻¹ only for the contacts on bodies coupled to the joints.
///
/// `storage` holds the step's intermediate vectors, reused from one step to the next.
pub fn velocity_step(
    start: &StepStart,
    active: &[ActiveContact],
    warm: &[Vector3<f64>],
    contacts: Option<&ActiveAt>,
    joints: Option<JointRowsAt>,
    storage: &mut VelocityStorage,
) -> VelocityStep {
    let params = start.params;
    // the joints' rows, eliminated at every Newton iterate (the first one before anything
    // reads them), and their impulses in `q_joint`
    let mut elimination = joints.map(|_| storage.elimination.take().unwrap_or_default());
    storage.fit(start.v0.len());
    let momentum_scale = storage.start_forces(start);
    // the rows the impulses act along (G) and those the end-of-step velocity meets (H, when
    // they differ): the start-of-step ones, but at the midpoint and the end for the
    // persistent contacts whose normal row turns
    let persistent = contacts.filter(|c| !c.persistent.is_empty() && params.h > 0.0);
    let turning = persistent.filter(|c| !c.turning.is_empty());
    storage.problem.start_rows(active, start.mask);
    storage.mu.clear();
    storage.mu.extend(active.iter().map(|c| c.mu));
    storage.impact_shifts(start, active, persistent);
    zeros(&mut storage.r, 3 * active.len());
    for (i, p) in warm.iter().enumerate() {
        storage.r.fixed_rows_mut::<3>(3 * i).copy_from(p);
    }
    // the last result's lists, written over
    let mut spent = storage.spent.take();
    let mut v = spent.as_mut().map_or(DVector::zeros(0), |s| {
        std::mem::replace(&mut s.v, DVector::zeros(0))
    });
    copy_into(&mut v, start.v0);
    let mut newton = NewtonOutcome::default();
    for it in 0..=params.newton_max_iterations {
        storage.residual_at(start, &v);
        if it > 0 {
            // converged when R(v) = Gᵀ P + Hᵀ Q to the tolerance
            let res = storage.unreacted_residual(elimination.as_deref(), start.mask);
            if res <= params.newton_tolerance * momentum_scale.max(f64::MIN_POSITIVE) || res == 0.0
            {
                newton.converged = true;
                break;
            }
            if it == params.newton_max_iterations {
                break;
            }
        }
        newton.iterations += 1;
        storage.free_velocity(start, &v);
        if turning.is_some() || joints.is_some() {
            advance_poses_into(
                &mut storage.mid,
                start.poses,
                start.v0,
                &v,
                0.5 * params.h,
                0.5,
            );
        }
        if let (Some(c), 1) = (turning, newton.iterations) {
            storage.turn_rows(c, active, start);
        }
        if let (Some(rows_at), Some(elimination)) = (joints, elimination.as_deref_mut()) {
            storage.eliminate_joints(elimination, rows_at, start);
        }
        if active.is_empty() {
            std::mem::swap(&mut storage.q_joint, &mut storage.q_free);
            v.copy_from(storage.free(elimination.is_some()));
            continue;
        }
        storage.solve_contacts(active, elimination.as_deref(), start, &mut newton);
        storage.apply_impulses(&mut v, elimination.is_some());
    }
    storage.result(v, active.len(), elimination, newton, spent)
}

/// How a velocity step's Newton loop ended.
struct NewtonOutcome {
    iterations: usize,
    converged: bool,
    /// The last contact solve's status, and whether its impacts were taken plastic.
    solver: SolverStatus,
    plastic: bool,
}

impl Default for NewtonOutcome {
    /// Before the first iteration: no contact problem, so nothing left unsolved.
    fn default() -> Self {
        NewtonOutcome {
            iterations: 0,
            converged: false,
            solver: SolverStatus {
                converged: true,
                ..Default::default()
            },
            plastic: false,
        }
    }
}

impl VelocityStorage {
    /// F₀ (with the settling damping) and M v₀ at the step's start; returns the momentum
    /// scale the Newton loop's residual is measured against.
    fn start_forces(&mut self, start: &StepStart) -> f64 {
        let (f0, mv) = (&mut self.f0, &mut self.mv);
        start
            .model
            .wrench(start.t, start.poses, start.v0, start.onset, f0);
        start.model.mass_times(start.v0, mv);
        f0.axpy(-start.damping, &*mv, 1.0);
        mv.norm() + start.params.h * f0.norm()
    }

    /// Each active contact's shift of its normal row in the velocity problem.
    ///
    /// Newton impact law: the shift e·U_N,k on the normal rows. A gap-law contact instead
    /// keeps g + h((1 − θ) U_N,k + θ U_N,k+1) ≥ 0: the shift (g + h(1 − θ) U_N,k)/(hθ), but
    /// never below 0. Where the start velocity alone already crosses (g + h(1 − θ) U_N,k < 0)
    /// it asks U_N,k+1 ≥ 0 only, as an ordinary contact would: requiring the body to move
    /// back could contradict a contact on the other side (the journal's closest point), and
    /// the projection removes what remains. A persistent contact takes no restitution: it
    /// is closed, and what its start-of-step rows show as approach is the turn of its frame
    /// over the last step (sliding along a concave surface), not an impact. One still open
    /// (a plastic impact taken at a gap) takes the gap law's shift: with shift 0 it would
    /// carry its load at a distance for good.
    fn impact_shifts(
        &mut self,
        start: &StepStart,
        active: &[ActiveContact],
        persistent: Option<&ActiveAt>,
    ) {
        let (h, theta) = (start.params.h, start.params.theta);
        let is_persistent = |c: usize| persistent.is_some_and(|p| p.persistent.contains(&c));
        self.shift.clear();
        self.shift.extend(active.iter().enumerate().map(|(k, c)| {
            let u0 = c.point.normal_velocity(start.v0.as_slice());
            let gap_law = |g: f64| ((g + h * (1.0 - theta) * u0) / (h * theta)).max(0.0);
            if c.point.gap_law && h > 0.0 {
                gap_law(c.point.gap())
            } else if is_persistent(k) {
                let g = c.point.gap();
                if h > 0.0 && g > start.params.admissible_depth() {
                    gap_law(g)
                } else {
                    0.0
                }
            } else {
                c.e * u0
            }
        }));
    }

    /// The end-of-step poses for the iterate `v`, and its residual
    /// R(v) = M(v − v₀) − hθF₁ − h(1−θ)F₀ in `resid`.
    fn residual_at(&mut self, start: &StepStart, v: &DVector<f64>) {
        let (model, h, theta) = (start.model, start.params.h, start.params.theta);
        let alpha = start.damping;
        advance_poses_into(&mut self.poses1, start.poses, start.v0, v, h, theta);
        model.wrench(start.t + h, &self.poses1, v, start.onset, &mut self.f1);
        if alpha > 0.0 {
            model.mass_times(v, &mut self.resid);
            self.f1.axpy(-alpha, &self.resid, 1.0);
        }
        for ((d, a), b) in self
            .dv
            .as_mut_slice()
            .iter_mut()
            .zip(v.as_slice())
            .zip(start.v0.as_slice())
        {
            *d = a - b;
        }
        model.mass_times(&self.dv, &mut self.resid);
        self.resid.axpy(-h * theta, &self.f1, 1.0);
        self.resid.axpy(-h * (1.0 - theta), &self.f0, 1.0);
    }

    /// What the residual leaves once the contact impulses (and the joints', through
    /// `elimination`) have answered it.
    fn unreacted_residual(&mut self, elimination: Option<&Elimination>, mask: &[bool]) -> f64 {
        match elimination {
            Some(e) => {
                e.unreacted(&self.q_joint, &self.resid, &mut self.unreacted);
                newton_residual(&self.unreacted, &self.problem.g, &self.r, mask)
            }
            None => newton_residual(&self.resid, &self.problem.g, &self.r, mask),
        }
    }

    /// The iteration matrix W at the iterate `v`, and the free velocity v − W⁻¹ R.
    fn free_velocity(&mut self, start: &StepStart, v: &DVector<f64>) {
        let (h, theta) = (start.params.h, start.params.theta);
        let t1 = start.t + h;
        let (model, mask) = (start.model, start.mask);
        let alpha = start.damping;
        self.w.assemble(
            model,
            mask,
            t1,
            &self.poses1,
            v,
            h,
            theta,
            alpha,
            start.onset,
        );
        self.v_free.copy_from(&self.resid);
        self.w.solve_mut(&mut self.v_free);
        self.v_free.zip_apply(v, |f, vi| *f = vi - *f);
    }

    /// The persistent contacts whose normal row turns over the step act along their mid-step
    /// rows and are measured along their end rows: a row that does not turn keeps the
    /// start rows (and the Delassus matrix symmetric, which the solver's sweeps need to
    /// converge fast), and so do one that swings (`SWUNG`) and one thrown with a guard.
    ///
    /// Under a projection, a closed contact whose bodies have a guard in the problem (a
    /// step that throws a journal across its clearance) keeps its start rows, as a swung
    /// one does. A ring's closest point on mid-step rows and its guards on start rows
    /// would let the solver carry large, nearly cancelling normal impulses, and the
    /// closest point's friction on them would take energy the motion does not lose; on
    /// start rows the energy a clearance pendulum loses to friction does not depend on
    /// the step.
    fn turn_rows(&mut self, c: &ActiveAt, active: &[ActiveContact], start: &StepStart) {
        let guarded = |p: &ContactPoint| {
            active
                .iter()
                .any(|g| g.point.gap_law && g.point.bodies() == p.bodies())
        };
        let projects = start.params.scheme.projects();
        (c.at)(&self.mid, &mut self.at_mid);
        (c.at)(&self.poses1, &mut self.at_end);
        for (k, &a) in c.turning.iter().enumerate() {
            let (at_mid, at_end) = (&mut self.at_mid[k], &mut self.at_end[k]);
            let start_point = active[a].point;
            let turn = at_mid
                .row_turn(start_point)
                .max(at_end.row_turn(start_point));
            let swung = projects && (turn > SWUNG || guarded(start_point));
            if turn <= ROW_TURN || swung {
                continue;
            }
            // the impulse and the velocity on the tangents of the start, carried over
            let frame = &active[a].point.frame;
            at_mid.carry_tangents_of(frame);
            at_end.carry_tangents_of(frame);
            self.problem.turn(a, at_mid, at_end, start.mask);
        }
    }

    /// Eliminates the joints: v = v_free + W⁻¹G(q_{k+½})ᵀ Q with H(q_{k+1}) v = b(t_{k+1}),
    /// the free velocity under the joints in `constrained`.
    fn eliminate_joints(
        &mut self,
        elimination: &mut Elimination,
        rows_at: JointRowsAt,
        start: &StepStart,
    ) {
        let (t, h) = (start.t, start.params.h);
        let (mid, end) = ((t + 0.5 * h, &self.mid[..]), (t + h, &self.poses1[..]));
        elimination.assemble(&self.w, rows_at, mid, end, start.mask);
        elimination.impulses_into(&self.v_free, &mut self.q_free);
        copy_into(&mut self.constrained, &self.v_free);
        elimination.add_response(&self.q_free, &mut self.constrained);
    }

    /// The free velocity the contacts see: under the joints where they are eliminated.
    fn free(&self, eliminated: bool) -> &DVector<f64> {
        match eliminated {
            true => &self.constrained,
            false => &self.v_free,
        }
    }

    /// The contacts' impulses in `r`.
    ///
    /// Mid-step and end rows make the Delassus matrix nonsymmetric. Where the solver does
    /// not solve that problem within `NONSYMMETRIC_SWEEPS`, the step solves it on its
    /// start-of-step rows instead, first order for that one step. Newton's law asks each
    /// impact to rebound at e times its approach. Where contacts jam, those rebounds
    /// together are met only by impulses beyond the step's `reach`, and they can give the
    /// bodies energy: the step then takes its impacts plastic.
    fn solve_contacts(
        &mut self,
        active: &[ActiveContact],
        elimination: Option<&Elimination>,
        start: &StepStart,
        newton: &mut NewtonOutcome,
    ) {
        let params = start.params;
        let eliminated = elimination.is_some();
        loop {
            let v_free = match eliminated {
                true => &self.constrained,
                false => &self.v_free,
            };
            self.problem
                .assemble(&self.w, elimination, v_free, &self.shift);
            let nonsymmetric = self.problem.turned;
            let opts = match nonsymmetric {
                true => NsgsOptions {
                    max_sweeps: NONSYMMETRIC_SWEEPS.min(params.solver.max_sweeps),
                    last_resort: false,
                    ..params.solver
                },
                false => params.solver,
            };
            let reach = reach(&self.problem.w, &self.problem.q);
            cap_warm_start(&mut self.r, reach);
            if nonsymmetric {
                copy_into(&mut self.before, &self.r);
            }
            let problem = Fc3d {
                w: &self.problem.w,
                q: &self.problem.q,
                mu: &self.mu,
            };
            newton.solver = solve_fc3d(&problem, &mut self.r, &opts, &mut self.solver);
            if nonsymmetric && !newton.solver.converged {
                self.r.copy_from(&self.before);
                self.problem.start_rows(active, start.mask);
            } else if self.r.amax() > reach && self.shift.iter().any(|&s| s < 0.0) {
                self.r.fill(0.0);
                self.shift.iter_mut().for_each(|s| *s = s.max(0.0));
                newton.plastic = true;
            } else {
                break;
            }
        }
    }

    /// The next iterate: the free velocity plus the contacts' responses to their impulses,
    /// and the joints' impulses less what the contacts' take from them.
    fn apply_impulses(&mut self, v: &mut DVector<f64>, eliminated: bool) {
        v.copy_from(self.free(eliminated));
        for (c, yc) in self.problem.ys.iter().enumerate() {
            let p = self.r.fixed_rows::<3>(3 * c);
            for (b, y) in yc {
                let mut seg = v.fixed_rows_mut::<6>(6 * b);
                seg += y * p;
            }
        }
        std::mem::swap(&mut self.q_joint, &mut self.q_free);
        for (c, corr) in self.problem.corrections.iter().enumerate() {
            if let Some(corr) = corr {
                self.q_joint -= corr * self.r.fixed_rows::<3>(3 * c);
            }
        }
    }

    /// The step's result at the last iterate `v`, with `contacts` active contacts, in the
    /// lists of the `spent` result where there is one.
    fn result(
        &self,
        v: DVector<f64>,
        contacts: usize,
        elimination: Option<Box<Elimination>>,
        newton: NewtonOutcome,
        spent: Option<VelocityStep>,
    ) -> VelocityStep {
        let (mut poses, mut normal_speeds, mut impulses, mut joint_impulses) = match spent {
            Some(s) => (s.poses, s.normal_speeds, s.impulses, s.joint_impulses),
            None => Default::default(),
        };
        // every pass of the Newton loop, the last included, starts by placing `poses1` at `v`
        poses.clear();
        poses.extend_from_slice(&self.poses1);
        normal_speeds.clear();
        let measured = |c: usize| self.problem.measured(c).velocity(&v).x;
        normal_speeds.extend((0..contacts).map(measured));
        impulses.clear();
        impulses.extend((0..contacts).map(|c| self.r.fixed_rows::<3>(3 * c).into_owned()));
        joint_impulses.clear();
        if elimination.is_some() {
            joint_impulses.extend_from_slice(self.q_joint.as_slice());
        }
        VelocityStep {
            poses,
            normal_speeds,
            impulses,
            v,
            joint_impulses,
            elimination,
            newton_iterations: newton.iterations,
            newton_converged: newton.converged,
            solver: newton.solver,
            plastic: newton.plastic,
        }
    }
}

/// A velocity step's storage, reused from one step to the next: the Newton loop's vectors,
/// the contact problem, the solver's storage and the joints' elimination. Every entry is
/// overwritten before it is read, so a step's result does not depend on what the last one
/// left in it.
#[derive(Default)]
pub struct VelocityStorage {
    f0: DVector<f64>,
    mv: DVector<f64>,
    f1: DVector<f64>,
    resid: DVector<f64>,
    dv: DVector<f64>,
    v_free: DVector<f64>,
    poses1: Vec<Pose>,
    /// The poses at mid-step, where the joints' and the persistent contacts' impulses act.
    mid: Vec<Pose>,
    w: IterationMatrix,
    /// The joints' impulses for the free velocity, those of the last iterate, the free
    /// velocity under the joints, and the residual their impulses leave.
    q_free: DVector<f64>,
    q_joint: DVector<f64>,
    constrained: DVector<f64>,
    unreacted: DVector<f64>,
    problem: ContactProblem,
    /// The contacts' friction coefficients and impact-law shifts in this step, their
    /// impulses, and those the nonsymmetric problem started from.
    mu: Vec<f64>,
    shift: Vec<f64>,
    r: DVector<f64>,
    before: DVector<f64>,
    /// The turning contacts at mid-step and at the step's end.
    at_mid: Vec<ContactPoint>,
    at_end: Vec<ContactPoint>,
    solver: SolverStorage,
    /// The joints' elimination, lent to a velocity step with joints, which hands it on
    /// with its result to the projection (`VelocityStep::elimination`).
    elimination: Option<Box<Elimination>>,
    /// The result of a velocity step once taken: the next result is written over its
    /// lists (`keep_spent`).
    spent: Option<VelocityStep>,
    /// A list of poses once done with (a state's, replaced), for `copy_poses`.
    spare_poses: Vec<Pose>,
}

impl VelocityStorage {
    /// Sizes the vectors for `n` degrees of freedom.
    fn fit(&mut self, n: usize) {
        for b in [
            &mut self.f0,
            &mut self.mv,
            &mut self.f1,
            &mut self.resid,
            &mut self.dv,
            &mut self.v_free,
        ] {
            buffer::fit(b, n);
        }
    }

    /// Keeps a velocity step's elimination, once done with, for the next step's.
    pub(super) fn keep_elimination(&mut self, elimination: Option<Box<Elimination>>) {
        if elimination.is_some() {
            self.elimination = elimination;
        }
    }

    /// Keeps a velocity step once done with: its elimination for the next step's, its
    /// lists for the next result.
    pub(super) fn keep_spent(&mut self, mut vs: VelocityStep) {
        self.keep_elimination(vs.elimination.take());
        self.spent = Some(vs);
    }

    /// A copy of `poses` in the storage of a list of poses once done with.
    pub(super) fn copy_poses(&mut self, poses: &[Pose]) -> Vec<Pose> {
        let mut copy = std::mem::take(&mut self.spare_poses);
        copy.clear();
        copy.extend_from_slice(poses);
        copy
    }

    /// Keeps a list of poses once done with, for `copy_poses`.
    pub(super) fn keep_poses(&mut self, poses: Vec<Pose>) {
        buffer::keep_larger(&mut self.spare_poses, poses);
    }
}

/// How many times the largest impulse that any one contact's free velocity calls for
/// (|q_c| / W_c,NN) a step's impulses may reach. Beyond it they are a jam, not what the
/// step asks: a journal wedged across its bore (μ above L_B / 2R_J) makes its contact
/// problem nearly singular, and the problem then carries equal and opposite pairs of any
/// size. The bundled scenes' impulses reach at most 4.3 times; the wedged journal's, up
/// to 3e9 times.
const REACH: f64 = 1e3;

/// `REACH` times the largest impulse that any one contact's free velocity calls for.
fn reach(w: &DMatrix<f64>, q: &DVector<f64>) -> f64 {
    (0..q.len() / 3)
        .map(|c| vector3(q, 3 * c).norm() / w[(3 * c, 3 * c)])
        .fold(0.0, f64::max)
        * REACH
}

/// Scales a warm start down to the step's `reach`. The wedged journal's symmetric problem,
/// on start rows, carries its pairs harmlessly: they cancel. Carried into a later step's
/// nonsymmetric problem, on whose mid-step rows a pair no longer cancels, a pair far
/// beyond the reach would give the mechanism energy.
fn cap_warm_start(r: &mut DVector<f64>, reach: f64) {
    let norm = r.amax();
    if norm > reach {
        *r *= reach / norm;
    }
}

/// The contact problem of a velocity step, kept from one step to the next with its
/// storage.
#[derive(Default)]
struct ContactProblem {
    /// Each contact's Jacobian blocks along which its impulse acts (G), and, when those of
    /// some persistent contact `turned`, those along which its velocity is measured (H):
    /// `h[c]` for a contact `apart[c]`, else its G.
    g: Vec<ContactBlocks>,
    h: Vec<ContactBlocks>,
    apart: Vec<bool>,
    turned: bool,
    /// Each contact's response W⁻¹Gᵀ along its impulse rows, sparse over the bodies; with
    /// joints, constrained (y − W⁻¹Hᵀ S⁻¹ H y).
    ys: Vec<Vec<(usize, Matrix6x3<f64>)>>,
    /// S⁻¹ H y of each contact: what its impulse takes from the joints' ones.
    corrections: Vec<Option<DMatrix<f64>>>,
    /// The responses on each body, as (contact, place in its response).
    on_body: Vec<Vec<(usize, usize)>>,
    /// The Delassus matrix and the free local velocity (shifted by the impact law).
    w: DMatrix<f64>,
    q: DVector<f64>,
    /// The blocks (c, d) of W written, all others zero.
    written: Vec<(usize, usize)>,
}

impl ContactProblem {
    /// Every contact on its start-of-step rows.
    fn start_rows(&mut self, active: &[ActiveContact], mask: &[bool]) {
        // over the entries the last step left (`ContactBlocks::write`)
        self.g.resize(active.len(), ContactBlocks::EMPTY);
        for (g, c) in self.g.iter_mut().zip(active) {
            g.write(c.point, mask);
        }
        self.turned = false;
    }

    /// Contact `a` acts along the rows of its point `mid` and is measured along those of
    /// `end`, on the moving bodies (`mask`).
    fn turn(&mut self, a: usize, mid: &ContactPoint, end: &ContactPoint, mask: &[bool]) {
        let n = self.g.len();
        if !self.turned {
            self.apart.clear();
            self.apart.resize(n, false);
            // over the entries the last step left, as `start_rows`
            self.h.resize(n, ContactBlocks::EMPTY);
            self.turned = true;
        }
        self.g[a].write(mid, mask);
        self.h[a].write(end, mask);
        self.apart[a] = true;
    }

    /// The rows contact `c`'s velocity is measured along.
    fn measured(&self, c: usize) -> &ContactBlocks {
        measured(&self.g, &self.h, &self.apart, self.turned, c)
    }

    /// Forms the problem for the iteration matrix `w`, the joints' `elimination`, the
    /// free velocity and the impact law's `shift`.
    fn assemble(
        &mut self,
        w: &IterationMatrix,
        elimination: Option<&Elimination>,
        v_free: &DVector<f64>,
        shift: &[f64],
    ) {
        let n = self.g.len();
        self.ys.truncate(n);
        self.ys.resize_with(n, Vec::new);
        for (y, b) in self.ys.iter_mut().zip(&self.g) {
            w.solve_blocks_into(b, y);
        }
        self.corrections.clear();
        if let Some(e) = elimination {
            self.corrections
                .extend(self.ys.iter_mut().map(|y| e.constrain(y)));
        }
        // Delassus blocks W_cd = Σ_b H_cb y_db over the bodies b both contacts move: the
        // responses indexed by body, so that only the nonzero blocks are formed
        let bodies = v_free.len() / 6;
        self.on_body.truncate(bodies);
        self.on_body.iter_mut().for_each(Vec::clear);
        self.on_body.resize_with(bodies, Vec::new);
        for (d, yd) in self.ys.iter().enumerate() {
            for (k, (b, _)) in yd.iter().enumerate() {
                self.on_body[*b].push((d, k));
            }
        }
        // only the blocks the last problem wrote are nonzero (a third of them on the circuit
        // breaker): zeroing those, not the whole matrix, saves a pass over the zero ones
        if self.w.shape() == (3 * n, 3 * n) {
            for &(c, d) in &self.written {
                self.w.fixed_view_mut::<3, 3>(3 * c, 3 * d).fill(0.0);
            }
        } else {
            self.w = DMatrix::zeros(3 * n, 3 * n);
        }
        self.written.clear();
        zeros(&mut self.q, 3 * n);
        // one shift per contact, as the index it replaces asked
        debug_assert_eq!(shift.len(), n, "one impact-law shift per contact");
        for (c, &shift) in shift.iter().enumerate() {
            let bc = measured(&self.g, &self.h, &self.apart, self.turned, c);
            let mut qc = bc.velocity(v_free);
            qc.x += shift;
            self.q.fixed_rows_mut::<3>(3 * c).copy_from(&qc);
            for (b, g) in bc.iter() {
                for &(d, k) in &self.on_body[*b] {
                    let mut blk = self.w.fixed_view_mut::<3, 3>(3 * c, 3 * d);
                    blk += g * self.ys[d][k].1;
                    self.written.push((c, d));
                }
            }
        }
    }
}

/// The rows contact `c` of a problem whose lists are `g`, `h` and `apart` is measured along
/// (`ContactProblem::measured`), from lists borrowed apart from the rest of the problem.
fn measured<'a>(
    g: &'a [ContactBlocks],
    h: &'a [ContactBlocks],
    apart: &[bool],
    turned: bool,
    c: usize,
) -> &'a ContactBlocks {
    match turned && apart[c] {
        true => &h[c],
        false => &g[c],
    }
}

/// ‖R − Σ Gᵀ P‖ over the integrated degrees of freedom.
fn newton_residual(
    resid: &DVector<f64>,
    blocks: &[ContactBlocks],
    r: &DVector<f64>,
    mask: &[bool],
) -> f64 {
    let mut sum = 0.0;
    for b in 0..resid.len() / 6 {
        let mut seg = resid.fixed_rows::<6>(6 * b).into_owned();
        for (c, blk) in blocks.iter().enumerate() {
            for (b2, g) in blk.iter() {
                if *b2 == b {
                    seg -= g.transpose() * r.fixed_rows::<3>(3 * c);
                }
            }
        }
        for k in 0..6 {
            if mask[6 * b + k] {
                sum += seg[k] * seg[k];
            }
        }
    }
    sum.sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;

    /// A step reads nothing that an earlier one left in its storage: the same run ends in
    /// the same state from fresh storage and from storage whose vectors were first filled
    /// with NaN, whose contact problem was left stale and of another size, and whose
    /// iteration matrix (and the joints' elimination with it) was assembled at NaN
    /// velocities, which any read before a write would spread. The ball bounces (a contact
    /// under Moreau–Jean); the four-bar's joints are eliminated and projected.
    #[test]
    fn a_step_reads_nothing_an_earlier_one_left_in_its_scratch() {
        let run = |name: &'static str, duration: f64, poison: bool| {
            let mut sim = Scene::bundled_simulation(name);
            if poison {
                let nan = || DVector::from_element(sim.state.v.len(), f64::NAN);
                let mask = sim.model.dof_mask();
                let poses = &sim.state.poses;
                let mut w = IterationMatrix::default();
                w.assemble(&sim.model, &mask, 0.0, poses, &nan(), 1e-3, 0.5, 0.0, &[]);
                // the joints' elimination formed with that matrix
                let mut elimination = Elimination::default();
                let rows_at = |t: f64, poses: &[Pose], out: &mut Vec<BilateralRow>| {
                    sim.model.joint_rows_into(t, poses, out)
                };
                elimination.assemble(&w, &rows_at, (0.0, poses), (0.0, poses), &mask);
                // a contact problem of another size, with stale rows and responses
                let stale = |n: usize| DVector::from_element(n, f64::NAN);
                let problem = ContactProblem {
                    g: Vec::new(),
                    h: Vec::new(),
                    apart: Vec::new(),
                    turned: true,
                    ys: vec![vec![(0, Matrix6x3::from_element(f64::NAN))]; 3],
                    corrections: Vec::new(),
                    on_body: vec![vec![(2, 0)]; 5],
                    w: DMatrix::from_element(3, 3, f64::NAN),
                    q: stale(3),
                    written: vec![(0, 0)],
                };
                let nan_pose = Pose {
                    x: Vector3::from_element(f64::NAN),
                    p: nalgebra::UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(
                        f64::NAN,
                        f64::NAN,
                        f64::NAN,
                        f64::NAN,
                    )),
                };
                let mut ws = Box::<crate::integrator::workspace::StepWorkspace>::default();
                ws.velocity.step = VelocityStorage {
                    f0: nan(),
                    mv: nan(),
                    f1: nan(),
                    resid: nan(),
                    dv: nan(),
                    v_free: nan(),
                    poses1: vec![nan_pose; poses.len() + 1],
                    mid: vec![nan_pose; poses.len() + 1],
                    w,
                    q_free: stale(5),
                    q_joint: stale(5),
                    constrained: nan(),
                    unreacted: nan(),
                    problem,
                    mu: vec![f64::NAN; 2],
                    shift: vec![f64::NAN; 2],
                    r: stale(3),
                    before: stale(3),
                    at_mid: Vec::new(),
                    at_end: Vec::new(),
                    solver: SolverStorage::default(),
                    elimination: Some(Box::new(elimination)),
                    spent: None,
                    spare_poses: vec![nan_pose; 2],
                };
                sim.workspace = Some(ws);
            }
            sim.run_until(duration, |_, _| {}).unwrap();
            sim.state
        };
        for (name, duration) in [("bouncing-ball", 1.0), ("four-bar", 0.2)] {
            let (fresh, poisoned) = (run(name, duration, false), run(name, duration, true));
            assert!(fresh.v.iter().all(|x| x.is_finite()), "{name}");
            assert_eq!(fresh, poisoned, "{name}");
        }
    }
}
