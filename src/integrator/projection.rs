//! Position projection onto the constraint manifolds (docs/method.md, "Activation and projection"), in twist
//! coordinates with the mass metric: with C the gradients of the projected rows,
//! solve (C M⁻¹ Cᵀ) Λ = −c(q) (equality rows; complementarity for contacts in direct
//! projection), Δν = M⁻¹ Cᵀ Λ and q ← q ⊕ Δν through the Lie-group update, so |p| = 1
//! holds by construction. Iterated (Gauss–Newton) until the violation is below tolerance;
//! joints alone first take chord steps on the velocity step's factors (`ChordStep`).
//! Velocities are not touched.

use super::rows;
use crate::math::blocks::vector6_at;
use crate::math::buffer;
use crate::mechanics::joint::{BilateralRow, Joint, RowUnit};
use crate::mechanics::{ContactPoint, Model, Motion, Pose};
use crate::solver::{solve_mixed_pgs, EqualitySolver};
use nalgebra::{DMatrix, DVector, Matrix6, RowVector6, Vector6};

/// Which contacts are projected and how.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ContactRows {
    /// g = 0 (combined projection: the pressed or penetrating active contacts).
    Equality,
    /// 0 ≤ g ⟂ Λ ≥ 0 (direct projection).
    Inequality,
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProjectionOutcome {
    pub iterations: usize,
    /// Largest violation before and after: |h| of joint rows, −g (or |g| for equality
    /// contacts) of the projected contacts.
    pub violation_before: f64,
    pub violation_after: f64,
    pub converged: bool,
    /// The joints' violations at the poses the projection left, which the run's
    /// statistics take there too.
    pub joint_violation: Option<JointViolation>,
}

/// The largest violations of the joints' rows at some time and poses: in length and in
/// angle.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct JointViolation {
    pub t: f64,
    pub length: f64,
    pub angle: f64,
}

impl JointViolation {
    /// Of the rows `rows` (the joints' at time `t`).
    pub fn of(t: f64, rows: &[BilateralRow]) -> Self {
        let mut v = JointViolation {
            t,
            ..Default::default()
        };
        for r in rows {
            match r.unit {
                RowUnit::Length => v.length = v.length.max(r.value.abs()),
                RowUnit::Angle => v.angle = v.angle.max(r.value.abs()),
            }
        }
        v
    }

    /// Of the joints of `model` at time `t` and `poses`, from their rows' values alone.
    pub fn at(model: &Model, t: f64, poses: &[Pose]) -> Self {
        let mut rows = Vec::with_capacity(model.joints.iter().map(Joint::row_count).sum());
        model.joint_row_values_into(t, poses, &mut rows);
        Self::of(t, &rows)
    }
}

/// How much farther than the start of the step a projection may land from the trial
/// before it is taken for a distant solution rather than the nearest admissible poses
/// (`Simulation::project_poses`). The start bounds the nearest poses exactly where it
/// satisfies every projected row; the factor allows for rows that were open at the start.
pub const PROJECTION_REACH: f64 = 2.0;

/// The distance between two sets of poses in the mass metric, √(Δνᵀ M Δν), Δν each
/// body's translation and body-frame rotation vector: the norm the projection minimises.
pub fn mass_distance(model: &Model, a: &[Pose], b: &[Pose]) -> f64 {
    let twice_kinetic: f64 = model
        .bodies
        .iter()
        .zip(a.iter().zip(b))
        .map(|(body, (a, b))| {
            let rotation = (a.p.inverse() * b.p).scaled_axis();
            2.0 * body.kinetic_energy(&(b.x - a.x), &rotation)
        })
        .sum();
    twice_kinetic.sqrt()
}

/// Whether `poses` lie no farther from `trial` than `PROJECTION_REACH` times the step's
/// own motion (from `start` to `trial`) plus `slack`, in the mass metric (`mass_distance`).
/// Bounds that take no arctangent decide it first: the translations alone bound the step's
/// motion from below, and a rotation's term is at most the trace of the inertia times
/// (π |v|)², v the vector part of its quaternion (its angle 2 atan2(|v|, |w|) is at most
/// π |v|). Only where they leave it open (within 1 %, for the rounding) are the distances
/// computed in full; the answer is that of the full test either way.
pub fn within_reach(
    model: &Model,
    trial: &[Pose],
    poses: &[Pose],
    start: &[Pose],
    slack: f64,
) -> bool {
    let (mut farthest, mut nearest) = (0.0, 0.0);
    for (body, ((t, p), s)) in model.bodies.iter().zip(trial.iter().zip(poses).zip(start)) {
        // the mass that translations move, as `Body::kinetic_energy` counts it
        let mass = if body.motion == Motion::Free {
            body.mass
        } else {
            0.0
        };
        let turn = std::f64::consts::PI * (t.p.inverse() * p.p).imag().norm();
        farthest += mass * (p.x - t.x).norm_squared() + body.inertia.trace() * turn * turn;
        nearest += mass * (s.x - t.x).norm_squared();
    }
    if 1.01 * farthest.sqrt() <= PROJECTION_REACH * nearest.sqrt() + slack {
        return true;
    }
    let moved = mass_distance(model, trial, poses);
    let allowed = PROJECTION_REACH * mass_distance(model, trial, start) + slack;
    // not farther: a NaN distance, which no bound decides, is within reach
    moved.partial_cmp(&allowed) != Some(std::cmp::Ordering::Greater)
}

/// `mass_distance` of moving every free body by `length`.
pub fn mass_distance_of_length(model: &Model, length: f64) -> f64 {
    let mass: f64 = model
        .bodies
        .iter()
        .filter(|b| b.motion == Motion::Free)
        .map(|b| b.mass)
        .sum();
    length * mass.sqrt()
}

/// Inverse mass matrix blocks (held dofs zero), the metric of the projection.
pub fn inverse_mass(model: &Model, mask: &[bool]) -> Vec<Matrix6<f64>> {
    model
        .bodies
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let mut m = Matrix6::zeros();
            if b.mass > 0.0 {
                for k in 0..3 {
                    m[(k, k)] = 1.0 / b.mass;
                }
            }
            if let Some(inv) = b.inertia.try_inverse() {
                m.fixed_view_mut::<3, 3>(3, 3).copy_from(&inv);
            }
            for r in 0..6 {
                for c in 0..6 {
                    if !mask[6 * i + r] || !mask[6 * i + c] {
                        m[(r, c)] = 0.0;
                    }
                }
            }
            m
        })
        .collect()
}

/// A correction Δν from the joint rows projected (their values c are all it reads), into
/// the vector given, that meets their linearisation, C Δν = −c (up to the rounding of its
/// solve): where the velocity step has just factorised such rows
/// (`Elimination::chord_step`), a chord step of the projection costs no factorisation of
/// its own. False where it has none.
pub type ChordStep<'a> = &'a mut dyn FnMut(&[BilateralRow], &mut DVector<f64>) -> bool;

/// The contacts to project at some poses: `contacts(poses, rows)` evaluates them there and
/// hands each to `ContactRowsOf::add`, which appends its rows (no list of points is made).
pub type ContactRowsAt<'a> = &'a dyn Fn(&[Pose], &mut ContactRowsOf);

/// The rows of the contacts projected, after the joints': the normal rows, and those whose
/// gap curves sharply across its normal.
#[derive(Default)]
pub struct ContactRowsOf {
    rows: Vec<BilateralRow>,
    /// (row index, the lateral displacement as a row, κ).
    curved: Vec<(usize, BilateralRow, f64)>,
}

impl ContactRowsOf {
    /// Room for `n` more contacts.
    pub fn reserve(&mut self, n: usize) {
        self.rows.reserve(n);
    }

    /// Appends the rows of the contact point `cp`.
    pub fn add(&mut self, cp: &ContactPoint) {
        if let Some(l) = cp.lateral {
            self.curved
                .push((self.rows.len(), contact_row(cp, l.g1, l.g2, 0.0), l.kappa));
        }
        self.rows.push(contact_normal_row(cp));
    }
}

/// Rows and violations of the constraints at some poses: the joint rows, then the
/// contacts' (`of`), with the contact rows whose gap curves sharply across its normal.
#[derive(Default)]
struct Evaluated {
    of: ContactRowsOf,
    njoint: usize,
    /// Whether the joint rows carry their gradients, which only a linearisation reads: a
    /// step tried is evaluated without them, and most steps kept end the projection.
    gradients: bool,
    /// Scratch of `with_gradients`.
    full: Vec<BilateralRow>,
    /// Largest violation (the convergence test) and the sum of squares (the merit).
    max: f64,
    squares: f64,
}

impl Evaluated {
    fn rows(&self) -> &[BilateralRow] {
        &self.of.rows
    }

    /// Re-evaluates the rows at `poses`, in place, the joint rows' gradients only if
    /// `gradients`.
    fn at(
        &mut self,
        model: &Model,
        t: f64,
        poses: &[Pose],
        contacts: ContactRowsAt,
        mode: ContactRows,
        gradients: bool,
    ) {
        self.of.rows.clear();
        self.of.curved.clear();
        match gradients {
            true => model.joint_rows_into(t, poses, &mut self.of.rows),
            false => model.joint_row_values_into(t, poses, &mut self.of.rows),
        }
        self.njoint = self.of.rows.len();
        self.gradients = gradients;
        contacts(poses, &mut self.of);
        let (mut max, mut squares) = (0.0f64, 0.0);
        for (k, r) in self.of.rows.iter().enumerate() {
            let v = if k >= self.njoint && mode == ContactRows::Inequality {
                (-r.value).max(0.0)
            } else {
                r.value.abs()
            };
            max = max.max(v);
            squares += v * v;
        }
        (self.max, self.squares) = (max, squares);
    }

    /// The joint rows' gradients, where `at` left them out: at the poses `at` was given.
    fn with_gradients(&mut self, model: &Model, t: f64, poses: &[Pose]) {
        if self.gradients {
            return;
        }
        self.full.clear();
        model.joint_rows_into(t, poses, &mut self.full);
        self.of.rows[..self.njoint].copy_from_slice(&self.full);
        self.gradients = true;
    }
}

/// Poses and their evaluation: the poses projected, or a step tried from them.
#[derive(Default)]
struct Trial {
    poses: Vec<Pose>,
    evaluated: Evaluated,
}

/// R X for the rows R and a matrix X with a row per dof, over each row's (at most two)
/// bodies only, added to `out` (rows × columns of X): R M⁻¹ Rᵀ without the dense product's
/// zeros (a held dof needs no mask here: its row of M⁻¹ Rᵀ is zero).
fn add_rows_times(rows: &[BilateralRow], x: &DMatrix<f64>, out: &mut DMatrix<f64>) {
    let n = x.nrows();
    for (k, row) in rows.iter().enumerate() {
        for (b, g) in row.a.iter().chain(row.b.iter()) {
            for (j, column) in x.as_slice().chunks_exact(n).enumerate() {
                // summed in order, as nalgebra's 1×6 by 6×1 product does
                let y = &column[6 * b..6 * b + 6];
                out[(k, j)] += (1..6).fold(g[0] * y[0], |s, i| s + g[i] * y[i]);
            }
        }
    }
}

/// A curvature term counts once its stiffness Λ κ, against the mass the lateral direction
/// sees (1 / L M⁻¹ Lᵀ), exceeds this ratio.
const CURVATURE_RATIO: f64 = 0.1;

/// Fixed-point passes on the multipliers of the curvature terms.
const CURVATURE_PASSES: usize = 8;

/// The storage of a linearised problem, kept from one projection to the next.
#[derive(Default)]
struct LinearStorage {
    mct: DMatrix<f64>,
    c: DVector<f64>,
    lambda: DVector<f64>,
    /// A = C M⁻¹ Cᵀ and its factors.
    solver: EqualitySolver,
    work: Vec<f64>,
}

/// The linearised projection problem at the current poses (C is `current.rows()`): M⁻¹ Cᵀ,
/// the values c and the Gauss–Newton multipliers Λ (H = M), where the curvature's fixed
/// point starts.
struct Linearised<'a> {
    current: &'a Evaluated,
    s: &'a mut LinearStorage,
    mode: ContactRows,
    tolerance: f64,
}

impl<'a> Linearised<'a> {
    fn new(
        current: &'a Evaluated,
        minv: &[Matrix6<f64>],
        ndof: usize,
        mode: ContactRows,
        tolerance: f64,
        s: &'a mut LinearStorage,
    ) -> Self {
        let rows = current.rows();
        rows::inverse_mass_times_rows_into(minv, rows, ndof, &mut s.mct);
        buffer::fit(&mut s.c, rows.len());
        for (c, r) in s.c.as_mut_slice().iter_mut().zip(rows) {
            *c = r.value;
        }
        let a = s.solver.zeroed(rows.len());
        add_rows_times(rows, &s.mct, a);
        let linear = Linearised {
            current,
            s,
            mode,
            tolerance,
        };
        if linear.inequality() {
            let lambda = linear.multipliers(linear.s.solver.matrix());
            linear.s.lambda = lambda;
        } else {
            let LinearStorage {
                c,
                lambda,
                solver,
                work,
                ..
            } = &mut *linear.s;
            solver.factorise();
            buffer::fit(lambda, c.len());
            lambda.zip_apply(c, |l, c| *l = -c);
            solver.solve_in_place(lambda.as_mut_slice(), work);
        }
        linear
    }

    /// Whether the contact rows are complementarity rows.
    fn inequality(&self) -> bool {
        self.mode == ContactRows::Inequality && self.current.rows().len() > self.current.njoint
    }

    /// Λ from A Λ = −c with A = C H⁻¹ Cᵀ (complementarity on the contact rows in
    /// `Inequality` mode).
    fn multipliers(&self, a: &DMatrix<f64>) -> DVector<f64> {
        let (n, njoint) = (self.current.rows().len(), self.current.njoint);
        if self.inequality() {
            // inequality rows: 0 ≤ w = c + A Λ ⟂ Λ ≥ 0 (pushes out only)
            let equality: Vec<bool> = (0..n).map(|k| k < njoint).collect();
            let mut z = DVector::zeros(n);
            solve_mixed_pgs(
                a,
                &self.s.c,
                &equality,
                &mut z,
                0.1 * self.tolerance,
                10_000,
            );
            z
        } else {
            EqualitySolver::new(a.clone()).solve(&(-&self.s.c))
        }
    }

    /// The Gauss–Newton correction Δν = M⁻¹ Cᵀ Λ, into `dnu`.
    fn gauss_newton(&self, dnu: &mut DVector<f64>) {
        buffer::fit(dnu, self.s.mct.nrows());
        self.s.mct.mul_to(&self.s.lambda, dnu);
    }

    /// The sequential-quadratic correction Δν = H⁻¹ Cᵀ Λ, H the mass matrix plus, for each
    /// sharply curved contact gap (`Lateral`), the Lagrangian's curvature term
    /// Λₖ κₖ Lₖᵀ Lₖ; `None` where no such term counts. A journal pinched between its bore's
    /// two rings at a micrometre clearance needs it: the Gauss–Newton step swings the bar
    /// about its centre of mass, which moves the journal sideways by a hundred clearances
    /// for a first-order gain, and the line search crawls. H⁻¹ comes from M⁻¹ by Woodbury's
    /// identity (one row per curved contact), Λ from a few fixed-point passes.
    fn curved(&self, mask: &[bool], minv: &[Matrix6<f64>], ndof: usize) -> Option<DVector<f64>> {
        let curved = &self.current.of.curved;
        if curved.is_empty() {
            return None;
        }
        let mct = &self.s.mct;
        let mut lambda = self.s.lambda.clone();
        let lateral: Vec<BilateralRow> = curved.iter().map(|c| c.1).collect();
        // C and L as dense matrices for the products with H⁻¹ Cᵀ, built only where this
        // step is tried (the Gauss–Newton step in `new` goes row by row)
        let (cmat, _) = rows::matrix(self.current.rows(), mask, ndof);
        let (lmat, _) = rows::matrix(&lateral, mask, ndof);
        let mlt = rows::inverse_mass_times_rows(minv, &lateral, ndof);
        let llt = &lmat * &mlt;
        let lmct = &lmat * mct;
        let stiffness = |lambda: &DVector<f64>| -> Vec<f64> {
            curved
                .iter()
                .map(|&(k, _, kappa)| lambda[k].max(0.0) * kappa)
                .collect()
        };
        let s = stiffness(&lambda);
        if (0..s.len()).all(|k| s[k] * llt[(k, k)] < CURVATURE_RATIO) {
            return None;
        }
        let mut hct = mct.clone();
        for _ in 0..CURVATURE_PASSES {
            let s = stiffness(&lambda);
            let on: Vec<usize> = (0..s.len()).filter(|&k| s[k] > 0.0).collect();
            if on.is_empty() {
                break;
            }
            // H⁻¹ Cᵀ = M⁻¹ Cᵀ − M⁻¹ Lᵀ (D⁻¹ + L M⁻¹ Lᵀ)⁻¹ L M⁻¹ Cᵀ, D = diag(Λₖ κₖ)
            let mut schur = llt.select_rows(&on).select_columns(&on);
            for (i, &k) in on.iter().enumerate() {
                schur[(i, i)] += 1.0 / s[k];
            }
            let chol = schur.cholesky()?;
            hct = mct - mlt.select_columns(&on) * chol.solve(&lmct.select_rows(&on));
            let next = self.multipliers(&(&cmat * &hct));
            let settled = (&next - &lambda).norm() <= 1e-3 * next.norm();
            lambda = next;
            if settled {
                break;
            }
        }
        Some(&hct * lambda)
    }
}

/// Step halvings tried before an iteration gives up.
const MAX_HALVINGS: usize = 8;

/// Steps tried from the poses `from`, whose evaluation has the merit `squares`: each in a
/// spare `Trial`, handed back when it is not kept.
struct Steps<'a> {
    model: &'a Model,
    t: f64,
    contacts: ContactRowsAt<'a>,
    mode: ContactRows,
    from: &'a [Pose],
    squares: f64,
    spare: &'a mut Vec<Trial>,
}

impl Steps<'_> {
    /// The poses `from` advanced by α Δν, if they lower the squared violation.
    fn try_step(&mut self, dnu: &DVector<f64>, alpha: f64) -> Option<Trial> {
        let mut trial = self.spare.pop().unwrap_or_default();
        trial.poses.clear();
        trial
            .poses
            .extend(self.from.iter().enumerate().map(|(b, pose)| {
                let d = alpha * vector6_at(dnu.as_slice(), 6 * b);
                if d != Vector6::zeros() {
                    pose.advanced(&d)
                } else {
                    *pose
                }
            }));
        let Trial { poses, evaluated } = &mut trial;
        evaluated.at(self.model, self.t, poses, self.contacts, self.mode, false);
        if evaluated.squares < self.squares {
            Some(trial)
        } else {
            self.spare.push(trial);
            None
        }
    }

    /// The step `dnu` halved from 2⁻ᶠⁱʳˢᵗ on until one lowers the violation.
    fn line_search(&mut self, dnu: &DVector<f64>, first: usize) -> Option<Trial> {
        (first..=MAX_HALVINGS).find_map(|k| self.try_step(dnu, 0.5f64.powi(k as i32)))
    }

    /// Keeps the storage of steps not taken.
    fn give_back(&mut self, trials: impl IntoIterator<Item = Option<Trial>>) {
        self.spare.extend(trials.into_iter().flatten());
    }

    /// The chord step `chord_step` makes for the joint rows `rows` (into `dnu`), where it
    /// at least halves the squared violation `squares`, as a full Gauss–Newton step must.
    fn chord(
        &mut self,
        chord_step: &mut ChordStep,
        rows: &[BilateralRow],
        dnu: &mut DVector<f64>,
        squares: f64,
    ) -> Option<Trial> {
        let step = match chord_step(rows, dnu) {
            true => self.try_step(dnu, 1.0),
            false => None,
        };
        match step {
            Some(next) if next.evaluated.squares <= 0.5 * squares => Some(next),
            step => {
                self.give_back([step]);
                None
            }
        }
    }

    /// The damped Gauss–Newton step along `dnu`, full or half; where neither does its work,
    /// the sequential-quadratic step `quadratic` gives (where a contact's gap bends sharply
    /// across its normal) halved as needed; else the full or half step that lowered the
    /// violation at all, else `dnu` halved further. A step that at least halves the squared
    /// violation (the linear model promises it falls to nothing, a quarter for the half
    /// step) is kept outright: the linearisation holds on its scale.
    fn damped(
        &mut self,
        dnu: &DVector<f64>,
        quadratic: impl FnOnce() -> Option<DVector<f64>>,
    ) -> Option<Trial> {
        let squares = self.squares;
        let halves = |step: &Option<Trial>| {
            step.as_ref()
                .is_some_and(|s| s.evaluated.squares <= 0.5 * squares)
        };
        let full = self.try_step(dnu, 1.0);
        if halves(&full) {
            return full;
        }
        let half = self.try_step(dnu, 0.5);
        if halves(&half) {
            self.give_back([full]);
            return half;
        }
        let quadratic = quadratic().and_then(|d| self.line_search(&d, 0));
        match (quadratic, full, half) {
            (Some(q), full, half) => {
                self.give_back([full, half]);
                Some(q)
            }
            (None, Some(full), half) => {
                self.give_back([half]);
                Some(full)
            }
            (None, None, Some(half)) => Some(half),
            (None, None, None) => self.line_search(dnu, 2),
        }
    }
}

/// The projection's storage, reused from one projection to the next by its caller (a
/// simulation's workspace). Every entry is written before it is read.
#[derive(Default)]
pub struct ProjectionStorage {
    spare: Vec<Trial>,
    linear: LinearStorage,
    gauss_newton: DVector<f64>,
}

/// Projects `poses` at time `t` onto the joints and the contacts `contacts` gives at the
/// poses it is given, with the chord steps `chord` while only joints are projected and
/// each at least halves the squared violation, in `storage`.
///
/// Damped Gauss–Newton: the full step, else the half step, is kept where it at least
/// halves the squared violation. Else, where a contact's gap bends sharply across its
/// normal, the sequential-quadratic step (`Linearised::curved`) is tried, halved as needed
/// (up to `MAX_HALVINGS` times); else the full or half step that lowered the violation at
/// all, else Gauss–Newton halved further. Where the constraint manifold is curved on the
/// scale of the correction (a ring contact at a clearance of nanometres, a journal that
/// crossed its clearance in one large step) the full step overshoots and the undamped
/// iteration wanders off; the damped one never leaves the poses worse than it found them.
///
/// Gauss–Newton stays first so that the projections its steps solve keep their path: a
/// study's outputs do not move with a rescue they do not need. The halving test keeps it
/// first at nanometre clearances too, where every ring is sharply curved and the half step
/// does the job; and a full step that lowers the violation only a little is not kept, as
/// it would zig-zag.
#[allow(clippy::too_many_arguments)]
pub fn project(
    model: &Model,
    mask: &[bool],
    minv: &[Matrix6<f64>],
    t: f64,
    poses: &mut [Pose],
    contacts: ContactRowsAt,
    mode: ContactRows,
    tolerance: f64,
    max_iterations: usize,
    mut chord: Option<ChordStep>,
    storage: &mut ProjectionStorage,
) -> ProjectionOutcome {
    let ProjectionStorage {
        spare,
        linear: storage,
        gauss_newton,
    } = storage;
    let ndof = 6 * model.bodies.len();
    let mut current = spare.pop().unwrap_or_default();
    // a chord step needs the rows' values alone
    current
        .evaluated
        .at(model, t, poses, contacts, mode, chord.is_none());
    let mut out = ProjectionOutcome {
        violation_before: current.evaluated.max,
        violation_after: current.evaluated.max,
        ..Default::default()
    };
    for it in 0..=max_iterations {
        let now = &current.evaluated;
        if out.ends_at(it, now, t, tolerance) || it == max_iterations {
            break;
        }
        let mut steps = Steps {
            model,
            t,
            contacts,
            mode,
            from: poses,
            squares: now.squares,
            spare,
        };
        // the chord step on the velocity step's elimination, while only joint rows are
        // projected and it at least halves the squared violation, as a full Gauss–Newton
        // step must; from the first that does not, Gauss–Newton
        let joints_only = now.njoint == now.rows().len();
        if let Some(chord_step) = chord.as_mut().filter(|_| joints_only) {
            let rows = now.rows();
            if let Some(next) = steps.chord(chord_step, rows, gauss_newton, now.squares) {
                poses.copy_from_slice(&next.poses);
                spare.push(std::mem::replace(&mut current, next));
                continue;
            }
            chord = None;
        }
        // the Gauss–Newton step, full or half; where neither does its work and a contact's
        // gap bends sharply across its normal, the sequential-quadratic step in its place,
        // halved as needed
        current.evaluated.with_gradients(model, t, poses);
        let now = &current.evaluated;
        let linear = Linearised::new(now, minv, ndof, mode, tolerance, storage);
        linear.gauss_newton(gauss_newton);
        if gauss_newton.iter().any(|x| !x.is_finite()) {
            break;
        }
        let quadratic = || {
            linear
                .curved(mask, minv, ndof)
                .filter(|d| d.iter().all(|x| x.is_finite()))
        };
        let Some(next) = steps.damped(gauss_newton, quadratic) else {
            break;
        };
        poses.copy_from_slice(&next.poses);
        spare.push(std::mem::replace(&mut current, next));
    }
    spare.push(current);
    out
}

impl ProjectionOutcome {
    /// Records iterate `it`, evaluated as `now` at time `t`; whether the projection ends
    /// there: it meets the tolerance (converged), or has no rows to project.
    fn ends_at(&mut self, it: usize, now: &Evaluated, t: f64, tolerance: f64) -> bool {
        self.iterations = it;
        self.violation_after = now.max;
        self.joint_violation = Some(JointViolation::of(t, &now.rows()[..now.njoint]));
        self.converged = now.max <= tolerance;
        self.converged || now.rows().is_empty()
    }
}

/// Normal rows (gap and its gradient) of contact points, as bilateral rows.
pub fn contact_normal_row(cp: &ContactPoint) -> BilateralRow {
    let (g1, g2) = cp.normal_rows();
    contact_row(cp, g1, g2, cp.gap())
}

/// A length row on a contact's two bodies, with the gradient blocks `g1`, `g2`.
fn contact_row(
    cp: &ContactPoint,
    g1: RowVector6<f64>,
    g2: RowVector6<f64>,
    value: f64,
) -> BilateralRow {
    BilateralRow {
        a: cp.body1.map(|i| (i, g1)),
        b: cp.body2.map(|i| (i, g2)),
        value,
        rate: 0.0,
        unit: RowUnit::Length,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;
    use nalgebra::{UnitQuaternion, Vector3};

    /// `within_reach` answers as the full test of `mass_distance` does, on the four-bar's
    /// three bars moved from a start to a trial (by translations, turns or both) and on to
    /// poses at 0.5 to 1.5 times the reach (by translations, turns of up to 2.5 rad, or
    /// both): where its bounds decide, and where they leave it to the full distances. A
    /// bound on a turn's term without its factor π, or a lower bound on the step that
    /// counted its turns, answers some of these wrongly.
    #[test]
    fn within_reach_is_the_test_of_the_mass_distance() {
        let sim = Scene::bundled_simulation("four-bar");
        let (model, start) = (&sim.model, &sim.state.poses);
        // each bar moved along its own direction of translation and turn, of the given sizes
        let moved = |poses: &[Pose], k: u64, length: f64, angle: f64| -> Vec<Pose> {
            poses
                .iter()
                .enumerate()
                .map(|(b, q)| {
                    let phase = (k * 7 + b as u64 * 3) as f64;
                    let along = Vector3::new(phase.sin(), (1.3 * phase).cos(), 0.5).normalize();
                    let about = Vector3::new((1.1 * phase).cos(), 0.4, (1.7 * phase).sin());
                    let mut delta = Vector6::zeros();
                    delta.fixed_rows_mut::<3>(0).copy_from(&(along * length));
                    delta
                        .fixed_rows_mut::<3>(3)
                        .copy_from(&(about.normalize() * angle));
                    q.advanced(&delta)
                })
                .collect()
        };
        let slack = mass_distance_of_length(model, 1e-10);
        let (mut agreed, mut inside) = (0u64, 0u64);
        let cases = 600u64;
        for k in 0..cases {
            let (length, angle) = [(1e-3, 0.0), (0.0, 1e-2), (1e-3, 1e-2)][(k % 3) as usize];
            let trial = moved(start, k, length, angle);
            let reach = PROJECTION_REACH * mass_distance(model, &trial, start);
            // poses at `ratio` times the reach, their move scaled to it once
            let ratio = 0.5 + (k as f64 * 0.618_034).fract();
            let (l, a) = [(1.0, 0.0), (0.0, 1.0), (0.5, 5.0)][(k / 3 % 3) as usize];
            let unit = mass_distance(model, &trial, &moved(&trial, k + 1000, l * 1e-3, a * 1e-3));
            let size = (ratio * reach / unit * 1e-3).min(2.5 / a.max(1e-9));
            let poses = moved(&trial, k + 1000, l * size, a * size);
            let full = mass_distance(model, &trial, &poses)
                <= PROJECTION_REACH * mass_distance(model, &trial, start) + slack;
            agreed += u64::from(within_reach(model, &trial, &poses, start, slack) == full);
            inside += u64::from(full);
        }
        assert_eq!(agreed, cases);
        assert!(
            inside > 150 && cases - inside > 150,
            "{inside} of {cases} within reach"
        );
    }

    /// The driven four-bar's poses knocked off its assembly by millimetres and
    /// hundredths of a radian.
    fn knocked(assembled: &[Pose]) -> Vec<Pose> {
        assembled
            .iter()
            .enumerate()
            .map(|(b, q)| Pose {
                x: q.x + Vector3::new(1e-3, -2e-3, 5e-4) * (b + 1) as f64,
                p: UnitQuaternion::from_scaled_axis(Vector3::new(0.01, -0.02, 0.015)) * q.p,
            })
            .collect()
    }

    /// Projects `poses` onto the joints of `sim`'s model at its time and tolerance, with the
    /// chord steps `chord`.
    fn project_joints(
        sim: &crate::integrator::Simulation,
        poses: &mut [Pose],
        chord: Option<ChordStep>,
        storage: &mut ProjectionStorage,
    ) -> ProjectionOutcome {
        project(
            &sim.model,
            &sim.mask,
            &sim.minv,
            sim.state.t,
            poses,
            &|_, _| {},
            ContactRows::Equality,
            sim.params.projection_tolerance,
            20,
            chord,
            storage,
        )
    }

    /// The driven four-bar (a closed loop: its 21 joint rows are redundant), knocked off
    /// its assembly, comes back onto its joints: to the tolerance, no farther from the
    /// knocked poses than the assembly is (the projection finds the nearest admissible
    /// poses in the mass metric), and bit for bit the same in fresh storage and in storage
    /// that holds NaNs from a larger problem.
    #[test]
    fn a_projection_reads_nothing_an_earlier_one_left() {
        let sim = Scene::bundled_simulation("four-bar");
        let (t, assembled) = (sim.state.t, sim.state.poses.clone());
        let knocked = knocked(&assembled);
        let tolerance = sim.params.projection_tolerance;
        let project_on = |poison: bool| {
            let mut poses = knocked.clone();
            let mut storage = ProjectionStorage::default();
            {
                if poison {
                    let nan = f64::NAN;
                    let row = BilateralRow {
                        a: Some((0, RowVector6::from_element(nan))),
                        b: None,
                        value: nan,
                        rate: nan,
                        unit: RowUnit::Length,
                    };
                    let trial = || Trial {
                        poses: vec![Pose::identity(); 9],
                        evaluated: Evaluated {
                            of: ContactRowsOf {
                                rows: vec![row; 40],
                                curved: vec![(3, row, nan)],
                            },
                            njoint: 7,
                            gradients: true,
                            full: vec![row; 40],
                            max: nan,
                            squares: nan,
                        },
                    };
                    storage = ProjectionStorage {
                        spare: (0..3).map(|_| trial()).collect(),
                        linear: LinearStorage {
                            mct: DMatrix::from_element(54, 40, nan),
                            c: DVector::from_element(40, nan),
                            lambda: DVector::from_element(40, nan),
                            solver: EqualitySolver::new(DMatrix::from_element(40, 40, nan)),
                            work: vec![nan; 120],
                        },
                        gauss_newton: DVector::from_element(54, nan),
                    };
                }
                let out = project_joints(&sim, &mut poses, None, &mut storage);
                (out, poses)
            }
        };
        let (out, poses) = project_on(false);
        assert!(out.converged && out.iterations >= 2, "{out:?}");
        assert!(out.violation_before > 1e-3, "{out:?}");
        let after = JointViolation::of(t, &sim.model.joint_rows(t, &poses));
        assert!(
            after.length <= tolerance && after.angle <= tolerance,
            "{after:?}"
        );
        let moved = mass_distance(&sim.model, &knocked, &poses);
        assert!(
            moved <= mass_distance(&sim.model, &knocked, &assembled),
            "{moved}"
        );
        let (out2, poses2) = project_on(true);
        assert_eq!(out, out2);
        assert_eq!(poses, poses2);
    }

    /// A chord step is kept only where it at least halves the squared violation. The chord
    /// of an elimination formed at the knocked four-bar's poses (the Gauss–Newton step but
    /// for its iteration matrix) takes them onto the joints, to the same nearest poses as
    /// Gauss–Newton. One that overshoots (three times that step), or that has none, leaves
    /// the projection to Gauss–Newton from where it stood: bit for bit the same poses.
    #[test]
    fn a_chord_step_is_kept_only_where_it_halves_the_violation() {
        use super::super::elimination::Elimination;
        use super::super::iteration_matrix::IterationMatrix;
        let sim = Scene::bundled_simulation("four-bar");
        let (t, h) = (sim.state.t, sim.params.h);
        let knocked = knocked(&sim.state.poses);
        let tolerance = sim.params.projection_tolerance;
        let run = |chord: Option<ChordStep>| {
            let mut poses = knocked.clone();
            let out = project_joints(&sim, &mut poses, chord, &mut Default::default());
            (out, poses)
        };
        let (plain_out, plain) = run(None);
        let mut w = IterationMatrix::default();
        let rest = DVector::zeros(sim.state.v.len());
        w.assemble(&sim.model, &sim.mask, t, &knocked, &rest, h, 0.5, 0.0, &[]);
        let mut elimination = Elimination::default();
        let rows_at = |t: f64, poses: &[Pose], out: &mut Vec<BilateralRow>| {
            sim.model.joint_rows_into(t, poses, out)
        };
        let at = (t, knocked.as_slice());
        elimination.assemble(&w, &rows_at, at, at, &sim.mask);

        let mut kept = 0;
        let (out, poses) = run(Some(
            &mut |rows: &[BilateralRow], dnu: &mut DVector<f64>| {
                kept += 1;
                elimination.chord_step(rows, dnu)
            },
        ));
        assert!(out.converged && plain_out.converged, "{out:?}");
        assert!(out.violation_after <= tolerance, "{out:?}");
        let moved = mass_distance(&sim.model, &knocked, &plain);
        let apart = mass_distance(&sim.model, &poses, &plain);
        assert!(
            kept >= 2 && apart <= 1e-6 * moved,
            "{kept}: {apart} of {moved}"
        );

        let overshoot = run(Some(
            &mut |rows: &[BilateralRow], dnu: &mut DVector<f64>| {
                let made = elimination.chord_step(rows, dnu);
                *dnu *= 3.0;
                made
            },
        ));
        assert_eq!(overshoot, (plain_out, plain.clone()));
        let none = run(Some(&mut |_: &[BilateralRow], _: &mut DVector<f64>| false));
        assert_eq!(none, (plain_out, plain));
    }
}
