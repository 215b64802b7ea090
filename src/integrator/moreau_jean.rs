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
use super::simulation::hand_back_points;
use crate::math::blocks::vector3;
use crate::math::buffer::{self, copy_into, zeros};
use crate::math::kept;
use crate::mechanics::body::{moves, Twist};
use crate::mechanics::joint::BilateralRow;
use crate::mechanics::{ContactPoint, Model, Pose};
use crate::solver::{solve_fc3d, Fc3d, NsgsOptions, SolverStatus};
use nalgebra::{ArrayStorage, DMatrix, DVector, Matrix3x6, Matrix6x3, Vector3};
use std::cell::RefCell;
use std::thread::LocalKey;

/// The joints' bilateral rows evaluated at a time and poses, appended to a list.
pub type JointRowsAt<'a> = &'a dyn Fn(f64, &[Pose], &mut Vec<BilateralRow>);

/// The active contacts at positions `which` evaluated at other poses, in a spare list
/// (`hand_back_points` keeps its storage once done with).
pub type ContactsAt<'a> = &'a dyn Fn(&[Pose], &[usize]) -> Vec<ContactPoint>;

/// The active contacts evaluated at other poses, and those of them that were closed when
/// the step began (persistent). Like the joints' rows (`Elimination`), a persistent
/// contact's impulse acts along its rows at the step's midpoint and its velocity is
/// measured at the step's end: a contact sliding along a concave surface, or carried on a
/// long lever by a turning body, then drifts off its surface by O(h³) per step instead of
/// O(h²) (a pendulum on a 10 mm clearance joint at h = 1e-4 sank 7.1e-4 m into its bore
/// in 1 s with start-of-step rows, 3.2e-5 m with these), and steady sliding along a
/// circle does no work. The Delassus matrix is then not symmetric, which slows the
/// solver. A contact that closes within the step keeps the rows it is given: the same rows
/// then measure its impulse and both velocities of Newton's law, which is what makes an
/// impact with e = 1 keep the kinetic energy and one with e < 1 lose it, at any step.
pub struct ActiveAt<'a> {
    /// Positions of the persistent contacts among the active ones, ascending.
    pub persistent: &'a [usize],
    /// Those of them whose normal can turn over a step, the ones evaluated at mid-step and
    /// at the end: a contact on a plane that cannot turn keeps its start rows, as any
    /// contact whose normal does not turn does, without being evaluated to find that out.
    pub turning: &'a [usize],
    /// The active contacts at positions `which` evaluated at the given poses, in order.
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
    /// whose normal turns, the start rows of any other.
    pub normal_speeds: Vec<f64>,
    pub newton_iterations: usize,
    pub newton_converged: bool,
    /// Impulse of each bilateral row (joint reactions over the step).
    pub joint_impulses: Vec<f64>,
    /// The joints' elimination the step ended with, factorised (`None` without joints):
    /// the step's projection takes its first steps with it (`Elimination::chord_step`),
    /// and `hand_back_elimination` keeps its storage for the next step.
    pub(super) elimination: Option<Box<Elimination>>,
    /// Status of the last FC3D solve (the one whose impulses are applied).
    pub solver: SolverStatus,
    /// Its impacts were taken plastic (e = 0): with restitution, the contacts jammed.
    pub plastic: bool,
}

/// Poses at the end of the step, q₁ = q₀ ⊕ h((1 − θ) v₀ + θ v₁), into `out`, whose
/// allocation the Newton iterations reuse.
fn advance_poses_into(
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

/// A persistent contact whose normal turns by more than this (rad) over its step acts on
/// its midpoint rows and meets its velocity condition on its end rows. Below, the start
/// rows differ from those by less than the solver's tolerance.
const NORMAL_TURN: f64 = 1e-6;

/// Under a projection, a persistent contact whose normal turns by more than this over its
/// step (a chord of 0.2, 11.5°) keeps its start rows: its rows at mid-step and at the end
/// are then those of other points, not of one point sliding along its surface, which is
/// what they stand for, and the projection removes the drift that start rows leave. A
/// journal that one step throws across its bore is such a contact: on the circuit breaker
/// with frictionless clearances of 1 nm, which must behave as the ideal mechanism,
/// mid-step and end rows up to a chord of 0.5 put the opening 1.5–4e-3 early (11–30 µs,
/// up to 1.1 σ of the toleranced study) over five perturbations of the step; up to 0.2,
/// 1.6–2.3e-4, as start-of-step rows do. Plain Moreau–Jean, which nothing takes out of
/// a wall, keeps these rows at any turn.
const SWUNG: f64 = 0.2;

/// Sweeps allowed a nonsymmetric contact problem (mid-step and end rows), with the global
/// Newton method they try on the way but without the last resort, before the step falls
/// back to its start-of-step rows. Gauss–Seidel needs symmetry to converge surely, and
/// the last resort's proximal iterations once took 6 s to fail on one step of a
/// circuit-breaker sample; the nominal sample's nonsymmetric problems take 1–14 sweeps and
/// Newton iterations (37 once).
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

fn contact_blocks(c: &ContactPoint, mask: &[bool]) -> ContactBlocks {
    let mut out = ContactBlocks::EMPTY;
    out.write(c, mask);
    out
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
pub fn velocity_step(
    start: &StepStart,
    active: &[ActiveContact],
    warm: &[Vector3<f64>],
    contacts: Option<&ActiveAt>,
    joints: Option<JointRowsAt>,
) -> VelocityStep {
    let StepStart {
        model,
        mask,
        params,
        damping: alpha,
        t,
        poses,
        v0,
    } = *start;
    let (h, theta) = (params.h, params.theta);
    let ndof = v0.len();
    let mut scratch = kept::take(&SCRATCH);
    scratch.fit(ndof);
    let Scratch {
        f0,
        mv,
        f1,
        resid,
        dv,
        v_free,
        poses1,
        mid,
        w,
        q_free,
        q_joint,
        constrained,
        unreacted,
        problem,
        mu,
        shift,
        r,
        before,
    } = &mut *scratch;
    model.wrench(t, poses, v0, f0);
    model.mass_times(v0, mv);
    f0.axpy(-alpha, &*mv, 1.0);
    let momentum_scale = mv.norm() + h * f0.norm();

    // the rows the impulses act along (G) and those the end-of-step velocity meets (H, when
    // they differ): the start-of-step ones, but at the midpoint and the end for the
    // persistent contacts whose normal turns
    let persistent = contacts.filter(|c| !c.persistent.is_empty() && h > 0.0);
    let turning = persistent.filter(|c| !c.turning.is_empty());
    problem.start_rows(active, mask);
    mu.clear();
    mu.extend(active.iter().map(|c| c.mu));
    // Under a projection, a closed contact whose bodies have a guard in the problem (a
    // step that throws a journal across its clearance) keeps its start rows, as a swung
    // one does. A ring's closest point on mid-step rows and its guards on start rows
    // let the solver carry large, nearly cancelling normal impulses, and the closest
    // point's friction on them took energy the motion does not lose: 204 N·s on the
    // ring and 181 N·s on a guard where the step needed 0.01, and 3.3 J of 4.9 gone
    // in 1 s from a pendulum on a 1 µm clearance at μ = 0.1 and h = 1e-3, which loses
    // 0.025–0.026 J at any step from 1e-5 to 1e-3 with these start rows.
    let guarded = |c: &ContactPoint| {
        active
            .iter()
            .any(|g| g.point.gap_law && g.point.bodies() == c.bodies())
    };
    // Newton impact law: the shift e·U_N,k on the normal rows. A gap-law contact instead
    // keeps g + h((1 − θ) U_N,k + θ U_N,k+1) ≥ 0: the shift (g + h(1 − θ) U_N,k)/(hθ), but
    // never below 0. Where the start velocity alone already crosses (g + h(1 − θ) U_N,k < 0)
    // it asks U_N,k+1 ≥ 0 only, as an ordinary contact would: requiring the body to move
    // back could contradict a contact on the other side (the journal's closest point), and
    // the projection removes what remains. A persistent contact takes no restitution: it
    // is closed, and what its start-of-step rows show as approach is the turn of its frame
    // over the last step (sliding along a concave surface), not an impact.
    let is_persistent = |c: usize| persistent.is_some_and(|p| p.persistent.contains(&c));
    shift.clear();
    shift.extend(active.iter().enumerate().map(|(k, c)| {
        let u0 = c.point.normal_velocity(v0.as_slice());
        if c.point.gap_law && h > 0.0 {
            ((c.point.gap() + h * (1.0 - theta) * u0) / (h * theta)).max(0.0)
        } else if is_persistent(k) {
            0.0
        } else {
            c.e * u0
        }
    }));
    zeros(r, 3 * active.len());
    for (i, p) in warm.iter().enumerate() {
        r.fixed_rows_mut::<3>(3 * i).copy_from(p);
    }
    // the joints' rows, eliminated at every Newton iterate (the first one before anything
    // reads them), and their impulses in `q_joint`
    let mut elimination = joints.map(|_| ELIMINATION.take().unwrap_or_default());
    let eliminated = elimination.is_some();

    let mut v = DVector::from_vec(spare_copy(&SPARE_VELOCITIES, v0.as_slice()));
    let mut status = SolverStatus {
        converged: true,
        ..Default::default()
    };
    let mut converged = false;
    let mut plastic = false;
    let mut iterations = 0;
    for it in 0..=params.newton_max_iterations {
        advance_poses_into(poses1, poses, v0, &v, h, theta);
        model.wrench(t + h, poses1, &v, f1);
        if alpha > 0.0 {
            model.mass_times(&v, resid);
            f1.axpy(-alpha, &*resid, 1.0);
        }
        // R(v) = M(v − v₀) − hθF₁ − h(1−θ)F₀
        for ((d, a), b) in dv
            .as_mut_slice()
            .iter_mut()
            .zip(v.as_slice())
            .zip(v0.as_slice())
        {
            *d = a - b;
        }
        model.mass_times(&*dv, resid);
        resid.axpy(-h * theta, &*f1, 1.0);
        resid.axpy(-h * (1.0 - theta), &*f0, 1.0);
        if it > 0 {
            // converged when R(v) = Gᵀ P + Hᵀ Q to the tolerance
            let res = match elimination.as_deref() {
                Some(e) => {
                    e.unreacted(q_joint, resid, unreacted);
                    newton_residual(unreacted, &problem.g, r, mask)
                }
                None => newton_residual(resid, &problem.g, r, mask),
            };
            if res <= params.newton_tolerance * momentum_scale.max(f64::MIN_POSITIVE) || res == 0.0
            {
                converged = true;
                break;
            }
            if it == params.newton_max_iterations {
                break;
            }
        }
        iterations += 1;
        w.assemble(model, mask, t + h, poses1, &v, h, theta, alpha);
        // v_free = v − W⁻¹ R, in the buffer kept across the iterations
        v_free.copy_from(&*resid);
        w.solve_mut(v_free);
        v_free.zip_apply(&v, |f, vi| *f = vi - *f);
        if turning.is_some() || joints.is_some() {
            advance_poses_into(mid, poses, v0, &v, 0.5 * h, 0.5);
        }
        if let (Some(c), 0) = (turning, iterations - 1) {
            let (mut at_mid, mut at_end) = ((c.at)(mid, c.turning), (c.at)(poses1, c.turning));
            for (k, &a) in c.turning.iter().enumerate() {
                // a normal that does not turn over the step keeps the start rows (and the
                // Delassus matrix symmetric, which the solver's sweeps need to converge
                // fast), and so do one that swings (`SWUNG`) and one thrown with a guard
                let n0 = active[a].point.frame.row(0);
                let turn = (at_mid[k].frame.row(0) - n0)
                    .norm()
                    .max((at_end[k].frame.row(0) - n0).norm());
                let swung = params.scheme.projects() && (turn > SWUNG || guarded(active[a].point));
                if turn <= NORMAL_TURN || swung {
                    continue;
                }
                // the impulse and the velocity on the tangents of the start, carried over
                let frame = &active[a].point.frame;
                at_mid[k].carry_tangents_of(frame);
                at_end[k].carry_tangents_of(frame);
                problem.turn(
                    a,
                    contact_blocks(&at_mid[k], mask),
                    contact_blocks(&at_end[k], mask),
                );
            }
            hand_back_points(at_mid);
            hand_back_points(at_end);
        }
        // eliminate the joints: v = v_free + W⁻¹G(q_{k+½})ᵀ Q with H(q_{k+1}) v = b(t_{k+1})
        if let (Some(rows_at), Some(elimination)) = (joints, elimination.as_deref_mut()) {
            elimination.assemble(w, rows_at, (t + 0.5 * h, mid), (t + h, poses1), mask);
            elimination.impulses_into(v_free, q_free);
            copy_into(constrained, v_free);
            elimination.add_response(q_free, constrained);
        }
        let v_free_c = match eliminated {
            true => &*constrained,
            false => &*v_free,
        };
        if active.is_empty() {
            std::mem::swap(q_joint, q_free);
            v.copy_from(v_free_c);
            continue;
        }
        // Mid-step and end rows make the Delassus matrix nonsymmetric. Where the solver does
        // not solve that problem within `NONSYMMETRIC_SWEEPS`, the step solves it on its
        // start-of-step rows instead, first order for that one step.
        // Newton's law asks each impact to rebound at e times its approach. Where contacts
        // jam, those rebounds together are met only by impulses beyond the step's `reach`,
        // and they can give the bodies energy: the step then takes its impacts plastic.
        loop {
            problem.assemble(w, elimination.as_deref(), v_free_c, shift);
            let nonsymmetric = problem.turned;
            let opts = match nonsymmetric {
                true => NsgsOptions {
                    max_sweeps: NONSYMMETRIC_SWEEPS.min(params.solver.max_sweeps),
                    last_resort: false,
                    ..params.solver
                },
                false => params.solver,
            };
            let reach = reach(&problem.w, &problem.q);
            cap_warm_start(r, reach);
            if nonsymmetric {
                copy_into(before, r);
            }
            status = solve_fc3d(
                &Fc3d {
                    w: &problem.w,
                    q: &problem.q,
                    mu,
                },
                r,
                &opts,
            );
            if nonsymmetric && !status.converged {
                r.copy_from(before);
                problem.start_rows(active, mask);
            } else if r.amax() > reach && shift.iter().any(|&s| s < 0.0) {
                r.fill(0.0);
                shift.iter_mut().for_each(|s| *s = s.max(0.0));
                plastic = true;
            } else {
                break;
            }
        }
        v.copy_from(v_free_c);
        for (c, yc) in problem.ys.iter().enumerate() {
            let p = r.fixed_rows::<3>(3 * c);
            for (b, y) in yc {
                let mut seg = v.fixed_rows_mut::<6>(6 * b);
                seg += y * p;
            }
        }
        std::mem::swap(q_joint, q_free);
        for (c, corr) in problem.corrections.iter().enumerate() {
            if let Some(corr) = corr {
                *q_joint -= corr * r.fixed_rows::<3>(3 * c);
            }
        }
    }
    let mut normal_speeds = kept::spare(&SPARE_NUMBERS);
    normal_speeds.extend(problem.measured().iter().map(|bc| bc.velocity(&v).x));
    let mut impulses = kept::spare(&SPARE_IMPULSES);
    impulses.extend((0..active.len()).map(|c| r.fixed_rows::<3>(3 * c).into_owned()));
    let mut joint_impulses = kept::spare(&SPARE_NUMBERS);
    if eliminated {
        joint_impulses.extend_from_slice(q_joint.as_slice());
    }
    // every pass of the Newton loop, the last included, starts by placing `poses1` at `v`
    VelocityStep {
        poses: spare_copy(&SPARE_POSES, poses1),
        v,
        impulses,
        normal_speeds,
        joint_impulses,
        elimination,
        newton_iterations: iterations,
        newton_converged: converged,
        solver: status,
        plastic,
    }
}

/// The Newton loop's vectors, kept from one step to the next on each thread (`kept`):
/// allocating and freeing them took 14 %
/// of the step of a bouncing ball or a free body. Every one is overwritten before it is
/// read, so the results do not depend on what a previous step left in them.
#[derive(Default)]
struct Scratch {
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
}

impl Scratch {
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
}

thread_local! {
    /// Taken by a velocity step and put back when it ends (a nested step would find none
    /// and make its own).
    static SCRATCH: kept::Slot<Scratch> = const { kept::Slot::new(None) };
    /// The joints' elimination, taken by a velocity step with joints and handed on with its
    /// result to the projection (`hand_back_elimination`).
    static ELIMINATION: kept::Slot<Elimination> = const { kept::Slot::new(None) };
}

/// Keeps the storage of a velocity step's elimination, once done with, for the next step on
/// this thread (one dropped instead is only built again).
pub(super) fn hand_back_elimination(elimination: Option<Box<Elimination>>) {
    if let Some(e) = elimination {
        ELIMINATION.set(Some(e));
    }
}

thread_local! {
    /// The lists a velocity step returns and a step lets go once it has taken them
    /// (`VelocityStep::hand_back`, `hand_back_poses`), kept for the next step on this
    /// thread: allocating and freeing them took 1.2 % of a pendulum step's instructions.
    /// Velocities and the short lists of numbers are kept apart, so that neither takes the
    /// other's storage and grows it at every step.
    static SPARE_VELOCITIES: kept::Spares<f64> = const { RefCell::new(Vec::new()) };
    static SPARE_NUMBERS: kept::Spares<f64> = const { RefCell::new(Vec::new()) };
    static SPARE_IMPULSES: kept::Spares<Vector3<f64>> = const { RefCell::new(Vec::new()) };
    static SPARE_POSES: kept::Spares<Pose> = const { RefCell::new(Vec::new()) };
}

/// A copy of `from` in the storage of a list handed back.
fn spare_copy<T: Copy>(spares: &'static LocalKey<kept::Spares<T>>, from: &[T]) -> Vec<T> {
    let mut v = kept::spare(spares);
    v.extend_from_slice(from);
    v
}

/// A copy of `poses` in the storage of a list of poses handed back.
pub(super) fn spare_poses(poses: &[Pose]) -> Vec<Pose> {
    spare_copy(&SPARE_POSES, poses)
}

/// Keeps the storage of a list of poses, once done with (a state's, replaced), for the next
/// `spare_poses` on this thread.
pub(super) fn hand_back_poses(poses: Vec<Pose>) {
    kept::hand_back(&SPARE_POSES, poses);
}

/// Fills this thread's spare step lists with stale entries of other sizes (for tests that
/// show a step reads nothing they held).
#[cfg(test)]
pub(super) fn poison_lists() {
    let pose = Pose {
        x: Vector3::from_element(f64::NAN),
        p: nalgebra::UnitQuaternion::identity(),
    };
    SPARE_VELOCITIES.set(vec![vec![f64::NAN; 40], vec![f64::NAN; 3]]);
    SPARE_NUMBERS.set(vec![vec![f64::NAN; 40]; 3]);
    SPARE_IMPULSES.set(vec![vec![Vector3::from_element(f64::NAN); 40]; 3]);
    SPARE_POSES.set(vec![vec![pose; 9], vec![pose; 1]]);
}

impl VelocityStep {
    /// Keeps the storage of the step's lists, once done with, for the next step on this
    /// thread; the elimination's with `hand_back_elimination`.
    pub(super) fn hand_back(self) {
        hand_back_poses(self.poses);
        kept::hand_back(&SPARE_VELOCITIES, self.v.data.into());
        kept::hand_back(&SPARE_IMPULSES, self.impulses);
        kept::hand_back(&SPARE_NUMBERS, self.normal_speeds);
        kept::hand_back(&SPARE_NUMBERS, self.joint_impulses);
        hand_back_elimination(self.elimination);
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
/// on start rows, carries its pairs harmlessly: they cancel. Its last resort once returned
/// one of 2.3e6 N·s where the step called for 1e-3; carried into a later step's
/// nonsymmetric problem, on whose mid-step rows the pair no longer cancels, it gave the
/// bar 11 J in one step.
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
    /// some persistent contact `turned`, those along which its velocity is measured (H).
    g: Vec<ContactBlocks>,
    h: Vec<ContactBlocks>,
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

    /// Contact `a` acts along `g` and is measured along `h`.
    fn turn(&mut self, a: usize, g: ContactBlocks, h: ContactBlocks) {
        if !self.turned {
            self.h.clone_from(&self.g);
            self.turned = true;
        }
        self.g[a] = g;
        self.h[a] = h;
    }

    /// The rows each contact's velocity is measured along.
    fn measured(&self) -> &[ContactBlocks] {
        match self.turned {
            true => &self.h,
            false => &self.g,
        }
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
        let measured = match self.turned {
            true => &self.h,
            false => &self.g,
        };
        for (c, bc) in measured.iter().enumerate() {
            let mut qc = bc.velocity(v_free);
            qc.x += shift[c];
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

    /// A step reads nothing that an earlier one left in its scratch: the same run ends in
    /// the same state on a fresh thread and on one whose scratch vectors were first filled
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
                w.assemble(&sim.model, &mask, 0.0, poses, &nan(), 1e-3, 0.5, 0.0);
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
                SCRATCH.set(Some(Box::new(Scratch {
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
                })));
                ELIMINATION.set(Some(Box::new(elimination)));
            }
            sim.run_until(duration, |_, _| {}).unwrap();
            sim.state
        };
        for (name, duration) in [("bouncing-ball", 1.0), ("four-bar", 0.2)] {
            let fresh = std::thread::spawn(move || run(name, duration, false))
                .join()
                .unwrap();
            let poisoned = std::thread::spawn(move || run(name, duration, true))
                .join()
                .unwrap();
            assert!(fresh.v.iter().all(|x| x.is_finite()), "{name}");
            assert_eq!(fresh, poisoned, "{name}");
        }
    }
}
