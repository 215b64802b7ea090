//! Nonsmooth Gauss–Seidel for FC3D with a one-contact Alart–Curnier Newton method and a
//! self-adaptive projection fallback. Contacts are swept in index
//! order, so results are deterministic; the caller passes the previous impulses as the
//! warm start.

use super::fc3d::{
    contact_rho, local_natural_map, natural_map_error, natural_map_error_at, project_on_cone, Fc3d,
    SolverStatus,
};
use super::newton::{global_newton, global_newton_from, proximal_newton, NewtonStorage};
use super::ordering::{block_is_nonzero, BlockPattern};
use crate::math::blocks::{block3, set_vector3, vector3};
use crate::math::buffer;
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

/// A problem of coupled contacts that is warm-started (from the last step's impulses) goes
/// to the global Newton method first; if that fails, and for one started from zero (new
/// impacts), NSGS sweeps and tries Newton after the first sweep, after this many sweeps
/// and after five times as many. On the circuit breaker most solves do not converge by
/// sweeping in a few sweeps (each journal's two pressed rings share its load in a nearly
/// redundant direction), and one or two Newton iterations from the warm start finish them:
/// a sweep before them only costs (3.5 % of a sample's instructions). From zero, a sweep
/// places the impacts for less than a Newton iteration. A problem of uncoupled contacts
/// (a single contact, for one) is solved by one sweep and never builds Newton's system.
const GLOBAL_NEWTON_AFTER: usize = 8;

/// Iterations of the global Newton method from the warm start, before any sweep: one
/// that needs more is far from the solution, where a sweep brings it closer for less.
const WARM_NEWTON: usize = 20;

/// Outer proximal-point iterations of the last resort. Jammed clearance joints at μ = 1
/// need 2–20 (a few up to several hundred); they run only on steps NSGS could not solve.
const PROXIMAL_OUTER: usize = 5000;

/// Sweeps without a 10 % improvement of the residual after which NSGS gives up.
const STAGNATION_SWEEPS: usize = 200;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NsgsOptions {
    /// Relative natural-map error to reach.
    pub tolerance: f64,
    /// Maximum number of sweeps over the contacts.
    pub max_sweeps: usize,
    /// Whether a problem that the sweeps leave unsolved goes on to the last resort: the
    /// global Newton method again, then proximal-point iterations (default true). These
    /// solve the jammed problems that stall Gauss–Seidel, but may take seconds to fail; a
    /// caller with another problem to fall back on turns them off.
    pub last_resort: bool,
}

impl Default for NsgsOptions {
    fn default() -> Self {
        NsgsOptions {
            tolerance: 1e-10,
            max_sweeps: 1000,
            last_resort: true,
        }
    }
}

/// The contact solver's storage, which a caller that solves one problem after another
/// (a simulation, step by step) keeps and hands to every solve: every entry is written
/// before it is read, so a solve's result does not depend on what an earlier one left.
#[derive(Default)]
pub struct SolverStorage {
    sweeps: Sweeps,
    newton: NewtonStorage,
}

/// The sweeps' storage.
#[derive(Default)]
struct Sweeps {
    /// Each contact's block of W and its inverse (for the sticking test).
    blocks: Vec<(Matrix3<f64>, BlockInverse)>,
    coupled: Coupling,
    /// The local velocity u = W r + q after a sweep.
    u: DVector<f64>,
    /// The iterate and its velocity, as the global Newton method takes them.
    trial: DVector<f64>,
    trial_u: DVector<f64>,
}

impl Sweeps {
    /// The natural-map error of `r`, its velocity u = W r + q left in `self.u`.
    fn error_at(&mut self, p: &Fc3d, r: &DVector<f64>) -> f64 {
        local_velocity(p, r, &self.blocks, &self.coupled, &mut self.u);
        natural_map_error_at(p, r, &self.u)
    }
}

/// Solves FC3D by NSGS in `storage`. `r` holds the warm start on entry and the impulses on
/// exit.
pub fn solve_fc3d(
    p: &Fc3d,
    r: &mut DVector<f64>,
    opts: &NsgsOptions,
    storage: &mut SolverStorage,
) -> SolverStatus {
    let SolverStorage { sweeps, newton } = storage;
    let n = p.mu.len();
    debug_assert_eq!(r.len(), 3 * n);
    if n == 0 {
        return SolverStatus {
            converged: true,
            iterations: 0,
            residual: 0.0,
        };
    }
    // each contact's block and its inverse (for the sticking test), fixed over the sweeps
    sweeps.blocks.clear();
    sweeps.blocks.extend((0..n).map(|a| {
        let block = block3(p.w, 3 * a, 3 * a);
        (block, BlockInverse::of(&block))
    }));
    // the contacts each one is coupled to, with their (nonzero) off-diagonal blocks W_ab:
    // contacts on bodies W does not couple leave each other's blocks zero, and skipping
    // them makes a sweep over a mechanism cost what its couplings cost
    sweeps.coupled.fill(p.w, n);
    let (mut best, mut best_sweep) = (f64::INFINITY, 0);
    if !sweeps.coupled.columns.is_empty() && r.iter().any(|&x| x != 0.0) {
        let residual = sweeps.error_at(p, r);
        let tolerance = opts.tolerance;
        if let Some(status) = newton_from(p, r, residual, sweeps, newton, tolerance, WARM_NEWTON, 0)
        {
            return status;
        }
    }
    for sweep in 1..=opts.max_sweeps {
        sweep_contacts(p, r, &sweeps.blocks, &sweeps.coupled);
        let residual = sweeps.error_at(p, r);
        if residual <= opts.tolerance || !residual.is_finite() {
            return SolverStatus {
                converged: residual.is_finite(),
                iterations: sweep,
                residual,
            };
        }
        // no progress for a while: report the failure rather than sweep on
        if residual < 0.9 * best {
            (best, best_sweep) = (residual, sweep);
        } else if sweep - best_sweep > STAGNATION_SWEEPS {
            return last_resort(p, sweeps.coupled.pattern(), r, opts, sweep, newton);
        }
        // Gauss–Seidel crawls on ill-conditioned Delassus matrices: what a sweep leaves
        // unsolved goes to the global Newton method from the sweep's iterate, and to more
        // sweeps if Newton fails
        if sweep == 1 || sweep == GLOBAL_NEWTON_AFTER || sweep == 5 * GLOBAL_NEWTON_AFTER {
            let tolerance = opts.tolerance;
            if let Some(status) = newton_from(p, r, residual, sweeps, newton, tolerance, 100, sweep)
            {
                return status;
            }
        }
    }
    last_resort(
        p,
        sweeps.coupled.pattern(),
        r,
        opts,
        opts.max_sweeps,
        newton,
    )
}

/// The global Newton method from `r`, at most `iterations` of them after `done` sweeps:
/// its solution in `r`, or `r` untouched if it fails. `sweeps.u` holds W r + q on entry,
/// and `residual` its natural-map error; an `r` that already solves the problem (a warm
/// start, often) costs no set-up.
#[allow(clippy::too_many_arguments)]
fn newton_from(
    p: &Fc3d,
    r: &mut DVector<f64>,
    residual: f64,
    sweeps: &mut Sweeps,
    newton: &mut NewtonStorage,
    tolerance: f64,
    iterations: usize,
    done: usize,
) -> Option<SolverStatus> {
    let Sweeps {
        blocks,
        coupled,
        u,
        trial,
        trial_u,
    } = sweeps;
    let (mut it, mut residual) = (0, residual);
    if residual > tolerance {
        buffer::copy_into(trial, r);
        buffer::copy_into(trial_u, u);
        let stop = (tolerance, iterations);
        let pattern = coupled.pattern();
        let reached = global_newton_from(p, pattern, trial, trial_u, residual, stop, newton)?;
        (it, residual) = (reached.iterations, reached.residual);
        std::mem::swap(r, trial);
        std::mem::swap(u, trial_u);
    }
    buffer::copy_into(trial, r);
    let residual = open_exactly(p, r, u, residual, trial, tolerance, |r, u| {
        local_velocity(p, r, blocks, coupled, u)
    });
    Some(SolverStatus {
        converged: true,
        iterations: done + it,
        residual,
    })
}

/// One Gauss–Seidel sweep: each contact in index order solved exactly for its own
/// impulse, the others' held at their latest values.
fn sweep_contacts(
    p: &Fc3d,
    r: &mut DVector<f64>,
    blocks: &[(Matrix3<f64>, BlockInverse)],
    coupled: &Coupling,
) {
    for (a, (block, inverse)) in blocks.iter().enumerate() {
        let o = 3 * a;
        let ra = vector3(r, o);
        // q_loc = q_a + Σ_{b≠a} W_ab r_b
        let mut qloc = vector3(p.q, o);
        for (b, w_ab) in coupled.of_contact(a) {
            qloc += w_ab * vector3(r, 3 * b);
        }
        let sol = solve_one_contact(block, inverse, &qloc, p.mu[a], &ra);
        set_vector3(r, o, &sol);
    }
}

/// The nonzero off-diagonal 3×3 blocks of W, row of blocks by row of blocks, and their
/// pattern as the global Newton method takes it.
#[derive(Default)]
struct Coupling {
    /// W_ab and its b for every contact a in turn, b ascending: contact a's are at
    /// `start[a]..start[a + 1]`.
    blocks: Vec<Matrix3<f64>>,
    columns: Vec<usize>,
    start: Vec<usize>,
    /// `start` and `columns` of the blocks held before, to tell whether the pattern changed.
    last_start: Vec<usize>,
    last_columns: Vec<usize>,
    /// The blocks' pattern, formed when Newton first needs it and kept while it stays the
    /// same (a contact problem keeps its pattern over most steps of a simulation).
    pattern: BlockPattern,
    pattern_formed: bool,
}

impl Coupling {
    /// The blocks of `w`, a matrix of n × n blocks, in place of those held.
    fn fill(&mut self, w: &DMatrix<f64>, n: usize) {
        std::mem::swap(&mut self.start, &mut self.last_start);
        std::mem::swap(&mut self.columns, &mut self.last_columns);
        let Coupling {
            blocks,
            start,
            columns,
            ..
        } = self;
        blocks.clear();
        start.clear();
        columns.clear();
        for a in 0..n {
            start.push(blocks.len());
            for b in (0..n).filter(|&b| b != a && block_is_nonzero(w, a, b)) {
                blocks.push(block3(w, 3 * a, 3 * b));
                columns.push(b);
            }
        }
        start.push(blocks.len());
        self.pattern_formed &= self.start == self.last_start && self.columns == self.last_columns;
    }

    /// W's block pattern, as the global Newton method takes it.
    fn pattern(&mut self) -> &BlockPattern {
        if !self.pattern_formed {
            let n = self.start.len() - 1;
            let Coupling {
                start,
                columns,
                pattern,
                ..
            } = self;
            let pairs =
                (0..n).flat_map(|a| columns[start[a]..start[a + 1]].iter().map(move |&b| (a, b)));
            pattern.set_pairs(n, pairs);
            self.pattern_formed = true;
        }
        &self.pattern
    }

    fn of_contact(&self, a: usize) -> impl Iterator<Item = (usize, &Matrix3<f64>)> {
        let run = self.start[a]..self.start[a + 1];
        self.columns[run.clone()]
            .iter()
            .copied()
            .zip(&self.blocks[run])
    }
}

/// The natural-map error of the global Newton method's solution `r` (with u = W r + q
/// and natural-map error `residual`), after setting to exactly zero the impulse of every
/// contact that the natural map says is open (P_K(r − ρ û) = 0), as a sweep's local solve
/// does; `r` is kept as it was (`kept` holds a copy) if that would leave the tolerance.
/// Newton leaves round-off impulses on separating contacts: on redundant corners, a
/// corner carrying 1e-14 of an impact that its neighbours do not counts as closed, and the
/// projection then holds it alone on its surface and tilts the body.
fn open_exactly(
    p: &Fc3d,
    r: &mut DVector<f64>,
    u: &mut DVector<f64>,
    residual: f64,
    kept: &DVector<f64>,
    tolerance: f64,
    velocity: impl Fn(&DVector<f64>, &mut DVector<f64>),
) -> f64 {
    let mut opened = false;
    for (a, &mu) in p.mu.iter().enumerate() {
        let o = 3 * a;
        let ra = vector3(r, o);
        if ra == Vector3::zeros() {
            continue;
        }
        let rho = contact_rho(&block3(p.w, o, o));
        if local_natural_map(&ra, &vector3(u, o), mu, rho) == ra {
            set_vector3(r, o, &Vector3::zeros());
            opened = true;
        }
    }
    if !opened {
        return residual;
    }
    velocity(r, u);
    let opened_residual = natural_map_error_at(p, r, u);
    if opened_residual <= tolerance {
        return opened_residual;
    }
    r.copy_from(kept);
    velocity(r, u);
    residual
}

/// u = W r + q over the nonzero blocks of W only (each contact's own and `coupled`), into
/// `u`.
fn local_velocity(
    p: &Fc3d,
    r: &DVector<f64>,
    blocks: &[(Matrix3<f64>, BlockInverse)],
    coupled: &Coupling,
    u: &mut DVector<f64>,
) {
    let rb = |b: usize| vector3(r, 3 * b);
    buffer::copy_into(u, p.q);
    for (a, (block, _)) in blocks.iter().enumerate() {
        let mut ua = vector3(u, 3 * a) + block * rb(a);
        for (b, w_ab) in coupled.of_contact(a) {
            ua += w_ab * rb(b);
        }
        set_vector3(u, 3 * a, &ua);
    }
}

/// NSGS and the global Newton both failed: try the global Newton again from the sweeps'
/// iterate, then proximal-point iterations (unless `opts.last_resort` is off); report the
/// failure if those fail too, with the best iterate found.
fn last_resort(
    p: &Fc3d,
    pattern: &BlockPattern,
    r: &mut DVector<f64>,
    opts: &NsgsOptions,
    sweeps: usize,
    newton: &mut NewtonStorage,
) -> SolverStatus {
    let found = opts
        .last_resort
        .then(|| {
            let mut trial = r.clone();
            let mut u = DVector::zeros(0);
            pattern.velocity_into(p.w, &trial, p.q, &mut u);
            let tolerance = opts.tolerance;
            let found = global_newton(p, pattern, &mut trial, &mut u, tolerance, 100, newton)
                .or_else(|| {
                    trial.copy_from(r);
                    proximal_newton(p, pattern, &mut trial, tolerance, PROXIMAL_OUTER, newton)
                });
            // the proximal iterations leave their best iterate, never worse than the sweeps' one
            *r = trial;
            found
        })
        .flatten();
    SolverStatus {
        converged: found.is_some(),
        iterations: sweeps + found.unwrap_or(0),
        residual: natural_map_error(p, r),
    }
}

/// A contact's block of W, inverted for the sticking test.
#[derive(Clone, Copy, Debug)]
pub struct BlockInverse {
    /// W⁻¹, or W⁺ where W is singular (None where that fails).
    pub matrix: Option<Matrix3<f64>>,
    /// W is singular: the contact's impulse is not unique (`solve_one_contact`).
    pub singular: bool,
}

/// A contact's block is singular where its determinant is below this fraction of
/// (tr W / 3)³, and of rank one where its second singular value is below this fraction of
/// its first; on a singular block, the normal impulse alone holds the point where it
/// leaves a velocity below this fraction of |q|.
const SINGULAR: f64 = 1e-10;

impl BlockInverse {
    /// W⁻¹ where W is regular, else W⁺.
    pub fn of(w: &Matrix3<f64>) -> Self {
        let size = (w.trace() / 3.0).abs();
        if w.determinant().abs() > SINGULAR * size * size * size {
            if let Some(inverse) = w.try_inverse() {
                return BlockInverse {
                    matrix: Some(inverse),
                    singular: false,
                };
            }
        }
        BlockInverse {
            matrix: pseudo_inverse(w),
            singular: true,
        }
    }
}

/// M⁺ of a singular 3×3 matrix, in closed form. The rows' cross products span M's right
/// null space and the columns' its left one (they are the adjugate's columns and rows).
/// Of rank two, with unit null vectors n_r, n_l and s = |M|: M + s n_l n_rᵀ is regular and
/// M⁺ = (M + s n_l n_rᵀ)⁻¹ − n_r n_lᵀ / s. Of rank one (the largest cross product, about
/// σ₁σ₂, below SINGULAR of |M|²), M = σ u vᵀ and M⁺ = v uᵀ / σ.
fn pseudo_inverse(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let largest = |v: [Vector3<f64>; 3]| v.into_iter().max_by(|a, b| a.norm().total_cmp(&b.norm()));
    let (r, c) = (
        |k: usize| m.row(k).transpose(),
        |k: usize| m.column(k).into_owned(),
    );
    let size = m.norm();
    let right = largest([r(1).cross(&r(2)), r(2).cross(&r(0)), r(0).cross(&r(1))])?;
    let left = largest([c(1).cross(&c(2)), c(2).cross(&c(0)), c(0).cross(&c(1))])?;
    if right.norm() > SINGULAR * size * size && left.norm() > SINGULAR * size * size {
        let (n_r, n_l) = (right.normalize(), left.normalize());
        let regular = m + n_l * n_r.transpose() * size;
        return Some(regular.try_inverse()? - n_r * n_l.transpose() / size);
    }
    let u = largest([c(0), c(1), c(2)])?.normalize();
    let v = largest([r(0), r(1), r(2)])?.normalize();
    let sigma = u.dot(&(m * v));
    (sigma != 0.0 && sigma.is_finite()).then(|| v * u.transpose() / sigma)
}

/// The damped least-squares inverse (MᵀM + δ²I)⁻¹ Mᵀ with δ 1e-7 of M's size: M⁺ to within
/// (δ/σ)² along each singular value σ ≫ δ, and small along M's null directions (a Newton
/// step's, which the next step corrects; the sticking impulse takes the exact M⁺).
fn least_norm_inverse(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let damping = (1e-7 * m.norm()).powi(2);
    let normal = m.transpose() * m + Matrix3::identity() * damping;
    Some(normal.try_inverse()? * m.transpose())
}

/// Exact solution of the one-contact problem u = W r + q, K* ∋ û ⟂ r ∈ K (to round-off),
/// starting from `r0`. Tries the closed-form separation and sticking solutions first, then
/// Alart–Curnier Newton for sliding, then the projection method if Newton stalls.
///
/// A singular W belongs to a contact on a part that its joints let move in fewer than three
/// directions at the point (a handle on its stop, turning about an ideal pivot): an impulse
/// along W's null directions moves nothing (the joints carry it), so the impulse is not
/// unique, and no impulse reaches the velocity outside W's range (round-off of the joints'
/// rows). The solve then takes the normal impulse alone where it holds the point (the
/// joints carry the rest), else the sticking impulse of least norm (W⁺ in place of W⁻¹),
/// else damped Newton steps that leave the null directions alone.
pub fn solve_one_contact(
    w: &Matrix3<f64>,
    inverse: &BlockInverse,
    q: &Vector3<f64>,
    mu: f64,
    r0: &Vector3<f64>,
) -> Vector3<f64> {
    // separation: r = 0 is a solution iff q_N ≥ 0
    if q.x >= 0.0 {
        return Vector3::zeros();
    }
    // the normal impulse alone that stops the point along its normal
    let normal_only = Vector3::new(-q.x / w[(0, 0)], 0.0, 0.0);
    if mu == 0.0 {
        return normal_only;
    }
    // a singular block: where the joints can carry the tangential impulse, the contact
    // carries none (the normal impulse alone holds the point)
    if inverse.singular && (w * normal_only + q).norm() <= SINGULAR * q.norm() {
        return normal_only;
    }
    // sticking: u = 0 with r inside the cone
    if let Some(inverse) = &inverse.matrix {
        let r = -(inverse * q);
        if r.x > 0.0 && (r.y * r.y + r.z * r.z).sqrt() <= mu * r.x {
            return r;
        }
    }
    // sliding: Alart–Curnier Newton from the warm start (or the normal-only guess)
    let start = if r0.x > 0.0 { *r0 } else { normal_only };
    let scale = start.norm().max((1.0 / w[(0, 0)]) * q.norm());
    if let Some(r) = alart_curnier_newton(w, q, mu, start, scale, inverse.singular) {
        return r;
    }
    projection_fallback(w, q, mu, start, scale)
}

/// Alart–Curnier function Φ(r) and one element of its generalized Jacobian.
fn alart_curnier(
    w: &Matrix3<f64>,
    q: &Vector3<f64>,
    mu: f64,
    rho_n: f64,
    rho_t: f64,
    r: &Vector3<f64>,
) -> (Vector3<f64>, Matrix3<f64>) {
    let u = w * r + q;
    let tau_n = r.x - rho_n * u.x;
    if tau_n <= 0.0 {
        return (*r, Matrix3::identity());
    }
    let mut phi = Vector3::zeros();
    let mut jac = Matrix3::zeros();
    phi.x = rho_n * u.x;
    jac.row_mut(0).copy_from(&(w.row(0) * rho_n));
    let tau_t = nalgebra::Vector2::new(r.y - rho_t * u.y, r.z - rho_t * u.z);
    let s = mu * tau_n;
    let nt = tau_t.norm();
    if nt <= s {
        phi.y = rho_t * u.y;
        phi.z = rho_t * u.z;
        jac.row_mut(1).copy_from(&(w.row(1) * rho_t));
        jac.row_mut(2).copy_from(&(w.row(2) * rho_t));
    } else {
        let x = tau_t / nt;
        phi.y = r.y - s * x.x;
        phi.z = r.z - s * x.y;
        // dτ_N/dr = e_N − ρ_N W_N ; dτ_T/dr = [0 I] − ρ_T W_T
        let dtn = nalgebra::RowVector3::new(1.0, 0.0, 0.0) - w.row(0) * rho_n;
        let mut dtt = nalgebra::Matrix2x3::new(0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        dtt -= w.fixed_rows::<2>(1) * rho_t;
        let proj = (nalgebra::Matrix2::identity() - x * x.transpose()) * (s / nt);
        let jt = nalgebra::Matrix2x3::new(0.0, 1.0, 0.0, 0.0, 0.0, 1.0) - x * dtn * mu - proj * dtt;
        jac.fixed_rows_mut::<2>(1).copy_from(&jt);
    }
    (phi, jac)
}

fn alart_curnier_newton(
    w: &Matrix3<f64>,
    q: &Vector3<f64>,
    mu: f64,
    mut r: Vector3<f64>,
    scale: f64,
    singular: bool,
) -> Option<Vector3<f64>> {
    let rho_n = 1.0 / w[(0, 0)];
    let rho_t = 1.0 / w[(1, 1)].max(w[(2, 2)]);
    let tol = 1e-15 * scale.max(f64::MIN_POSITIVE);
    let (mut phi, mut jac) = alart_curnier(w, q, mu, rho_n, rho_t, &r);
    for _ in 0..50 {
        let f0 = phi.norm_squared();
        if f0.sqrt() <= tol {
            return Some(r);
        }
        // a singular W can leave the Jacobian singular along W's null directions: the step
        // of least norm leaves the impulse there as it is
        let inverse = match singular {
            false => jac.try_inverse()?,
            true => least_norm_inverse(&jac)?,
        };
        let dr = inverse * (-phi);
        // Armijo backtracking on ½‖Φ‖²
        let mut t = 1.0;
        loop {
            let trial = r + dr * t;
            let (p2, j2) = alart_curnier(w, q, mu, rho_n, rho_t, &trial);
            if p2.norm_squared() <= (1.0 - 1e-4 * t) * f0 || t < 1e-12 {
                r = trial;
                phi = p2;
                jac = j2;
                break;
            }
            t *= 0.5;
        }
        if t < 1e-12 {
            return None;
        }
    }
    (phi.norm() <= 1e3 * tol).then_some(r)
}

/// Projection iterations r ← P_K(r − ρ û) with the self-adaptive step of Siconos'
/// `fc3d_projection`: slow but always converges for a positive definite block.
fn projection_fallback(
    w: &Matrix3<f64>,
    q: &Vector3<f64>,
    mu: f64,
    mut r: Vector3<f64>,
    scale: f64,
) -> Vector3<f64> {
    let mut rho = contact_rho(w);
    let tol = 1e-15 * scale.max(f64::MIN_POSITIVE);
    for _ in 0..10_000 {
        let u = w * r + q;
        let ut = (u.y * u.y + u.z * u.z).sqrt();
        let uhat = Vector3::new(u.x + mu * ut, u.y, u.z);
        let mut next = project_on_cone(&(r - uhat * rho), mu);
        // self-adaptive step: shrink until ρ‖Δu‖ ≤ 0.9 ‖Δr‖
        for _ in 0..60 {
            let dr = next - r;
            let du = w * dr;
            if rho * du.norm() <= 0.9 * dr.norm() {
                if rho * du.norm() < 0.3 * dr.norm() {
                    rho *= 1.5;
                }
                break;
            }
            rho *= 2.0 / 3.0;
            next = project_on_cone(&(r - uhat * rho), mu);
        }
        r = next;
        if local_natural_map(&r, &(w * r + q), mu, contact_rho(w)).norm() <= tol {
            break;
        }
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two contacts pressed along nearly the same direction (the two rings of a journal):
    /// W's normal block is [[1, 1 − ε], [1 − ε, 1]], on which Gauss–Seidel gains only a
    /// factor (1 − ε)² a sweep. The first sweep hands the problem to the global Newton
    /// method, not GLOBAL_NEWTON_AFTER of them. Both
    /// contacts press, so that W r + q = 0: r_N = 1 / (2 − ε) on each, with no friction.
    #[test]
    fn a_crawl_goes_to_newton_at_once() {
        let eps = 1e-3;
        let mut w = DMatrix::<f64>::identity(6, 6);
        w[(0, 3)] = 1.0 - eps;
        w[(3, 0)] = 1.0 - eps;
        let q = DVector::from_vec(vec![-1.0, 0.0, 0.0, -1.0, 0.0, 0.0]);
        let mu = [0.5, 0.5];
        let p = Fc3d {
            w: &w,
            q: &q,
            mu: &mu,
        };
        let mut r = DVector::zeros(6);
        let status = solve_fc3d(
            &p,
            &mut r,
            &NsgsOptions::default(),
            &mut SolverStorage::default(),
        );
        assert!(status.converged && status.residual <= 1e-10, "{status:?}");
        // one sweep, then at most two Newton iterations
        assert!(status.iterations <= 3, "{status:?}");
        // the sum is set by W's stiff direction (eigenvalue 2 − ε), the difference by its
        // soft one (ε), which the tolerance leaves 1/ε times looser
        assert!((r[0] + r[3] - 2.0 / (2.0 - eps)).abs() <= 1e-9, "{r}");
        assert!((r[0] - r[3]).abs() <= 1e-6, "{r}");
        assert!([1, 2, 4, 5].iter().all(|&k| r[k] == 0.0), "{r}");
    }

    /// Two contacts coupled as a body's corners are, the second separating (u_N = 1 with
    /// r = 0). A round-off impulse left on the second (as the global Newton method leaves)
    /// is set to exactly zero, and the first keeps its own. Where the iterate with the
    /// open contacts zeroed would not meet the tolerance, the iterate is kept as it was.
    #[test]
    fn newton_leaves_open_contacts_with_exactly_zero_impulse() {
        let mut w = DMatrix::<f64>::identity(6, 6);
        w[(0, 3)] = 0.5;
        w[(3, 0)] = 0.5;
        // the first contact pressed (W r + q = 0 at r_N = 1), the second leaving at u_N = 1
        // once the first carries its impulse
        let q = DVector::from_vec(vec![-1.0, 0.0, 0.0, 0.5, 0.0, 0.0]);
        let mu = [0.0, 0.0];
        let p = Fc3d {
            w: &w,
            q: &q,
            mu: &mu,
        };
        let velocity = |r: &DVector<f64>, u: &mut DVector<f64>| *u = &w * r + &q;
        let opened = |tiny: f64, tolerance: f64| {
            let mut r = DVector::from_vec(vec![1.0, 0.0, 0.0, tiny, 0.0, 0.0]);
            let kept = r.clone();
            let mut u = DVector::zeros(6);
            velocity(&r, &mut u);
            let e = natural_map_error(&p, &r);
            let residual = open_exactly(&p, &mut r, &mut u, e, &kept, tolerance, velocity);
            assert_eq!(residual, natural_map_error(&p, &r), "{r}");
            assert_eq!(u, &w * &r + &q);
            r
        };
        let r = opened(1e-14, 1e-7);
        assert_eq!(r, DVector::from_vec(vec![1.0, 0.0, 0.0, 0.0, 0.0, 0.0]));
        // the first contact off its solution by 1e-3: zeroing the second leaves that error,
        // above a tolerance of 1e-6, so r is kept
        let mut r = DVector::from_vec(vec![1.001, 0.0, 0.0, 1e-14, 0.0, 0.0]);
        let kept = r.clone();
        let mut u = DVector::zeros(6);
        velocity(&r, &mut u);
        let e = natural_map_error(&p, &r);
        let residual = open_exactly(&p, &mut r, &mut u, e, &kept, 1e-6, velocity);
        assert_eq!(r, kept);
        assert_eq!(residual, natural_map_error(&p, &r));
        assert!(residual > 1e-6, "{residual}");
    }

    /// A contact on a part that turns about an ideal pivot (the handle of a toggle clamp
    /// on its stop): W = λ d dᵀ has rank one, with round-off off its range, and q = −c d
    /// pushes the point along d. The normal impulse alone holds it, r_N = c / (λ d_N):
    /// the pivot carries the tangential load, whatever the warm start, even one on the
    /// cone's edge with a part along W's null directions.
    #[test]
    fn a_singular_block_sticks_with_the_normal_impulse_alone() {
        let d = Vector3::new(1.0, 0.15, 0.05).normalize();
        let noise = Matrix3::new(3e-15, -1e-15, 2e-15, 1e-15, -2e-15, 0.0, 0.0, 4e-15, 1e-15);
        let w = d * d.transpose() * 2.5 + noise;
        let off_range = d.cross(&Vector3::z()).normalize();
        let q = d * -0.01 + off_range * 1e-14;
        let inverse = BlockInverse::of(&w);
        assert!(inverse.singular);
        let expected = Vector3::new(0.01 / (2.5 * d.x), 0.0, 0.0);
        let edge = Vector3::new(1.0, 0.18, 0.0669).normalize() * 4.7e-3;
        for r0 in [Vector3::zeros(), expected, edge] {
            let r = solve_one_contact(&w, &inverse, &q, 0.2, &r0);
            assert!(
                (r - expected).norm() <= 1e-12 * expected.norm(),
                "from {r0}: {r}"
            );
        }
    }

    /// A rank-two block (the tangent along a planar mechanism's pivot axes moves nothing)
    /// on which the point needs friction to stick: the sticking impulse of least norm,
    /// nothing along the null direction. Pushed harder along the tangent, it slides: r_N =
    /// −q_N / W_NN and the friction μ r_N against the slip.
    #[test]
    fn a_singular_block_sticks_or_slides_with_nothing_along_its_null_direction() {
        let w = Matrix3::from_diagonal(&Vector3::new(147.0, 0.0, 33.0));
        let mu = 0.1;
        let inverse = BlockInverse::of(&w);
        assert!(inverse.singular);
        let zero = Vector3::zeros();
        let sticks = solve_one_contact(&w, &inverse, &Vector3::new(-1.0, 0.0, -1e-3), mu, &zero);
        let expected = Vector3::new(1.0 / 147.0, 0.0, 1e-3 / 33.0);
        assert!((sticks - expected).norm() <= 1e-15, "{sticks}");
        let slides = solve_one_contact(&w, &inverse, &Vector3::new(-1.0, 0.0, -5.0), mu, &zero);
        let expected = Vector3::new(1.0 / 147.0, 0.0, mu / 147.0);
        assert!((slides - expected).norm() <= 1e-14, "{slides}");
    }

    /// The closed-form pseudo-inverse of singular blocks, nonsymmetric, of rank one and
    /// two, against the SVD's.
    #[test]
    fn a_singular_block_inverts_as_the_svd_does() {
        let (a, b) = (Vector3::new(0.3, -1.2, 0.7), Vector3::new(2.0, 0.4, -0.5));
        let (c, d) = (Vector3::new(-0.6, 0.1, 1.1), Vector3::new(0.2, 1.5, 0.9));
        for m in [
            a * b.transpose() * 3.0,
            a * b.transpose() + c * d.transpose(),
        ] {
            let svd = m.pseudo_inverse(1e-12).unwrap();
            let closed = pseudo_inverse(&m).unwrap();
            assert!(
                (closed - svd).norm() <= 1e-12 * svd.norm(),
                "{closed} {svd}"
            );
            assert!(BlockInverse::of(&m).singular);
        }
    }

    /// A solve reads nothing that an earlier one left in its storage: two coupled
    /// contacts, one sliding, solve to the same bits in fresh storage and in storage that
    /// a larger problem used before.
    #[test]
    fn a_solve_reads_nothing_an_earlier_one_left() {
        let w = DMatrix::from_fn(6, 6, |i, j| {
            let base = if i == j { 2.0 + 0.1 * i as f64 } else { 0.0 };
            base + if i / 3 != j / 3 && (i + j) % 2 == 0 {
                0.3
            } else {
                0.0
            }
        });
        let q = DVector::from_vec(vec![-1.0, 0.8, 0.1, -0.5, 0.0, 0.05]);
        let mu = [0.3, 0.5];
        let solve = |storage: &mut SolverStorage| {
            let p = Fc3d {
                w: &w,
                q: &q,
                mu: &mu,
            };
            let mut r = DVector::zeros(6);
            let status = solve_fc3d(&p, &mut r, &NsgsOptions::default(), storage);
            (status, natural_map_error(&p, &r), r)
        };
        // storage used by three coupled contacts, pressed and sliding
        let mut used = SolverStorage::default();
        let w3 = DMatrix::from_fn(9, 9, |i, j| if i == j { 3.0 } else { 0.4 });
        let q3 = DVector::from_fn(9, |i, _| if i % 3 == 0 { -1.0 } else { 0.7 });
        let p3 = Fc3d {
            w: &w3,
            q: &q3,
            mu: &[0.2, 0.4, 0.6],
        };
        let mut r3 = DVector::zeros(9);
        assert!(solve_fc3d(&p3, &mut r3, &NsgsOptions::default(), &mut used).converged);
        let (fresh, error, r) = solve(&mut SolverStorage::default());
        assert!(fresh.converged && error <= 1e-10, "{fresh:?} {error}");
        // the first contact slides: its friction is on the cone's boundary
        assert!(
            (r[1].hypot(r[2]) - mu[0] * r[0]).abs() <= 1e-9 * r[0],
            "{r}"
        );
        let (reused, _, r2) = solve(&mut used);
        assert_eq!(fresh, reused);
        assert_eq!(r, r2);
    }

    /// Newton's block pattern follows W's from one solve to the next: three contacts
    /// coupled as 0–1, then as 1–2 (the same size, another pattern), warm-started so that
    /// the global Newton method solves them, solve to the same bits in storage that the
    /// other pattern used as in fresh storage.
    #[test]
    fn newtons_pattern_follows_the_coupling() {
        let coupled_as = |pair: (usize, usize)| {
            DMatrix::from_fn(9, 9, move |i, j| {
                let (a, b) = (i / 3, j / 3);
                if i == j {
                    2.0 + 0.1 * i as f64
                } else if (a, b) == pair || (b, a) == pair {
                    0.9 / (1.0 + (i + j) as f64)
                } else {
                    0.0
                }
            })
        };
        let q = DVector::from_fn(9, |i, _| if i % 3 == 0 { -1.0 } else { 0.3 });
        let mu = [0.3, 0.5, 0.4];
        let solve = |w: &DMatrix<f64>, storage: &mut SolverStorage| {
            let p = Fc3d { w, q: &q, mu: &mu };
            // a warm start that is not the solution
            let mut r = DVector::from_fn(9, |i, _| if i % 3 == 0 { 0.4 } else { 0.01 });
            let status = solve_fc3d(&p, &mut r, &NsgsOptions::default(), storage);
            assert!(status.converged && status.iterations > 0, "{status:?}");
            assert!(natural_map_error(&p, &r) <= 1e-10);
            (status, r)
        };
        let (first, second) = (coupled_as((0, 1)), coupled_as((1, 2)));
        let fresh = [&first, &second].map(|w| solve(w, &mut SolverStorage::default()));
        let mut used = SolverStorage::default();
        for (w, fresh) in [
            (&first, &fresh[0]),
            (&second, &fresh[1]),
            (&first, &fresh[0]),
        ] {
            assert_eq!(&solve(w, &mut used), fresh);
        }
    }
}
