//! Global Alart–Curnier nonsmooth Newton on the whole FC3D problem, over W's nonzero
//! blocks, the second solver of Alart and Curnier (docs/method.md): quadratic convergence
//! where Gauss–Seidel crawls, e.g. two contacts a few millimetres apart on a long body (the
//! two rings of a clearance joint), whose Delassus matrix is ill-conditioned.

use super::block_lu::BlockLu;
use super::fc3d::{natural_map_error, natural_map_error_at, Fc3d};
use super::ordering::{BlockPattern, MinimumDegree};
use crate::math::blocks::{block3, set_vector3, vector3};
use crate::math::buffer;
use nalgebra::{DVector, Matrix2, Matrix3, RowVector3, Vector2, Vector3};

/// Φ of one contact and its derivatives A = ∂Φ/∂r, B = ∂Φ/∂u.
fn local(
    u: &Vector3<f64>,
    r: &Vector3<f64>,
    mu: f64,
    rho_n: f64,
    rho_t: f64,
) -> (Vector3<f64>, Matrix3<f64>, Matrix3<f64>) {
    let tau_n = r.x - rho_n * u.x;
    if tau_n <= 0.0 {
        return (*r, Matrix3::identity(), Matrix3::zeros());
    }
    let mut phi = Vector3::zeros();
    let mut a = Matrix3::zeros();
    let mut b = Matrix3::zeros();
    phi.x = rho_n * u.x;
    b[(0, 0)] = rho_n;
    let tau_t = Vector2::new(r.y - rho_t * u.y, r.z - rho_t * u.z);
    let s = mu * tau_n;
    let nt = tau_t.norm();
    if nt <= s {
        phi.y = rho_t * u.y;
        phi.z = rho_t * u.z;
        b[(1, 1)] = rho_t;
        b[(2, 2)] = rho_t;
    } else {
        let x = tau_t / nt;
        phi.y = r.y - s * x.x;
        phi.z = r.z - s * x.y;
        let p = (Matrix2::identity() - x * x.transpose()) * (s / nt);
        let en = RowVector3::new(1.0, 0.0, 0.0);
        let sel = nalgebra::Matrix2x3::new(0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        let at = sel - x * en * mu - p * sel;
        let bt = x * en * (mu * rho_n) + p * sel * rho_t;
        a.fixed_rows_mut::<2>(1).copy_from(&at);
        b.fixed_rows_mut::<2>(1).copy_from(&bt);
    }
    (phi, a, b)
}

/// Φ at the impulses `r`, whose velocity u = W r + q is `u`, into `phi`, and on request
/// its Jacobian, into the factors' storage `jac`, contact a at elimination position
/// `position[a]`.
fn phi_and_jacobian(
    p: &Fc3d,
    pattern: &BlockPattern,
    r: &DVector<f64>,
    u: &DVector<f64>,
    rho: &[(f64, f64)],
    phi: &mut DVector<f64>,
    mut jac: Option<(&mut BlockLu, &[usize])>,
) {
    let n = p.mu.len();
    // every entry of Φ is written below; J's blocks outside W's pattern stay zero
    buffer::fit(phi, 3 * n);
    for (a, &(rho_n, rho_t)) in rho.iter().enumerate().take(n) {
        let o = 3 * a;
        let (ua, ra) = (vector3(u, o), vector3(r, o));
        let (f, da, db) = local(&ua, &ra, p.mu[a], rho_n, rho_t);
        set_vector3(phi, o, &f);
        if let Some((j, position)) = jac.as_mut() {
            // J = A + B W on the contact's rows, over W's nonzero blocks (the diagonal
            // block among them)
            for &b in pattern.row(a) {
                let mut jab = db * block3(p.w, o, 3 * b);
                if b == a {
                    jab += da;
                }
                *j.block_mut(position[a], position[b]) = jab;
            }
        }
    }
}

/// Damped Newton from `r`, whose velocity W r + q the caller holds in `u` (a solver that
/// tested its iterate has it already); returns the iterations used if it reached
/// `tolerance` (relative natural-map error), leaving the best iterate in `r` and its
/// velocity in `u` either way. `pattern` is W's block pattern (`BlockPattern::of`, or
/// `of_pairs` from blocks already found). The Jacobian is
/// factorised in its blocks (`BlockLu`), the contacts taken in a fill-reducing order
/// (`BlockPattern::minimum_degree_into`), so that storage and work follow the pattern's
/// fill-in rather than the problem's size. `storage` is the method's, reused from one call
/// to the next.
pub fn global_newton(
    p: &Fc3d,
    pattern: &BlockPattern,
    r: &mut DVector<f64>,
    u: &mut DVector<f64>,
    tolerance: f64,
    max_iterations: usize,
    storage: &mut NewtonStorage,
) -> Option<usize> {
    let residual = natural_map_error_at(p, r, u);
    let stop = (tolerance, max_iterations);
    global_newton_from(p, pattern, r, u, residual, stop, storage).map(|s| s.iterations)
}

/// A solution the global Newton method reached: the iterations it took and its
/// natural-map error.
#[derive(Clone, Copy, Debug)]
pub struct Reached {
    pub iterations: usize,
    pub residual: f64,
}

/// `global_newton` for a caller that knows the natural-map error `residual` of `r` (with
/// velocity `u`) and wants the solution's: it is evaluated once at every iterate, by the
/// method only. `(tolerance, max_iterations)` is where it stops.
pub fn global_newton_from(
    p: &Fc3d,
    pattern: &BlockPattern,
    r: &mut DVector<f64>,
    u: &mut DVector<f64>,
    residual: f64,
    (tolerance, max_iterations): (f64, usize),
    storage: &mut NewtonStorage,
) -> Option<Reached> {
    let NewtonStorage {
        order,
        ordered,
        ordering,
        iterates:
            Iterates {
                rho,
                u_trial,
                phi,
                phi_trial,
                factors,
                position,
                dr,
                trial,
            },
    } = storage;
    // the order, each contact's place in it and the factors' pattern are functions of W's
    // pattern alone: formed again when it changed
    if ordered != pattern {
        pattern.minimum_degree_into(order, ordering);
        ordered.clone_from(pattern);
        factors.set_pattern(pattern, order);
        position.clear();
        position.resize(order.len(), 0);
        for (k, &a) in order.iter().enumerate() {
            position[a] = k;
        }
    }
    let n = p.mu.len();
    rho.clear();
    rho.extend((0..n).map(|a| {
        let o = 3 * a;
        let wn = p.w[(o, o)].max(f64::MIN_POSITIVE);
        let wt = p.w[(o + 1, o + 1)]
            .max(p.w[(o + 2, o + 2)])
            .max(f64::MIN_POSITIVE);
        (1.0 / wn, 1.0 / wt)
    }));
    // the step and the trial, every entry written at each use
    buffer::fit(dr, r.len());
    buffer::fit(trial, r.len());
    let mut residual = residual;
    for it in 0..max_iterations {
        if residual <= tolerance {
            return Some(Reached {
                iterations: it,
                residual,
            });
        }
        factors.clear_fill();
        phi_and_jacobian(p, pattern, r, u, rho, phi, Some((factors, position)));
        let f0 = phi.norm_squared();
        // Redundant contacts (the two rings of a clearance joint share the axial slip
        // direction) make J singular but the equations consistent: a tiny diagonal shift
        // keeps the step defined without changing the solution.
        let shift = 1e-10 * factors.amax().max(f64::MIN_POSITIVE);
        if !factors.factorise(shift) {
            return None;
        }
        // the step −J⁻¹Φ, solved in elimination positions
        for (k, &a) in order.iter().enumerate() {
            for c in 0..3 {
                trial[3 * k + c] = -phi[3 * a + c];
            }
        }
        factors.solve_in_place(trial.as_mut_slice());
        for (k, &a) in order.iter().enumerate() {
            for c in 0..3 {
                dr[3 * a + c] = trial[3 * k + c];
            }
        }
        let mut t = 1.0;
        loop {
            trial.zip_zip_apply(r, dr, |x, r, d| *x = r + d * t);
            pattern.velocity_into(p.w, trial, p.q, u_trial);
            phi_and_jacobian(p, pattern, trial, u_trial, rho, phi_trial, None);
            if phi_trial.norm_squared() <= (1.0 - 1e-4 * t) * f0 {
                r.copy_from(trial);
                std::mem::swap(u, u_trial);
                residual = natural_map_error_at(p, r, u);
                break;
            }
            t *= 0.5;
            if t < 1e-10 {
                return None;
            }
        }
    }
    (residual <= tolerance).then_some(Reached {
        iterations: max_iterations,
        residual,
    })
}

/// The global Newton method's storage, reused from one solve to the next: every entry is
/// written before it is read, and the order and the factors' pattern are kept with the
/// pattern they were formed for.
#[derive(Default)]
pub struct NewtonStorage {
    /// The contacts' fill-reducing order, the pattern it and `iterates.factors` are for, and
    /// the ordering's scratch.
    order: Vec<usize>,
    ordered: BlockPattern,
    ordering: MinimumDegree,
    iterates: Iterates,
}

/// The Newton iterations' vectors and matrices.
#[derive(Default)]
struct Iterates {
    /// Each contact's (ρ_N, ρ_T).
    rho: Vec<(f64, f64)>,
    /// The velocity at the line search's trial.
    u_trial: DVector<f64>,
    /// Φ at the iterate and at the trial.
    phi: DVector<f64>,
    phi_trial: DVector<f64>,
    /// The Jacobian of Φ, formed in the storage of its factors, and each contact's
    /// elimination position (kept with `order`).
    factors: BlockLu,
    position: Vec<usize>,
    /// The Newton step and the trial impulses.
    dr: DVector<f64>,
    trial: DVector<f64>,
}

/// Proximal-point iterations r ← sol FC3D(W + ηI, q − η r), each
/// solved by the global Newton method, whose Jacobian the shift η makes nonsingular. For
/// the jammed, rank-deficient problems where Gauss–Seidel stalls and the plain Newton's line
/// search stops (a journal wedged between the two rings and a flange of a clearance joint
/// at μ = 1: 18 unknowns on 6 degrees of freedom), the iterates move along the soft
/// directions of W that both miss. η adapts: a small η moves fast but its subproblem is
/// nearly as singular as the original, so η shrinks threefold after every solved
/// subproblem and grows tenfold when the inner Newton fails (from η = mean diag W it starts
/// again at 1e-4 from the best iterate); a fixed η would either fail its subproblems or
/// creep. Returns the inner Newton iterations used if the
/// *original* problem reached `tolerance`; `r` holds the best iterate either way. `pattern`
/// is W's, which the shift keeps.
pub fn proximal_newton(
    p: &Fc3d,
    pattern: &BlockPattern,
    r: &mut DVector<f64>,
    tolerance: f64,
    max_outer: usize,
    storage: &mut NewtonStorage,
) -> Option<usize> {
    let mean_diag = p.w.diagonal().mean().max(f64::MIN_POSITIVE);
    let (mut rel, mut total) = (1e-4, 0);
    let mut current = r.clone();
    let mut best = natural_map_error(p, r);
    let mut w = p.w.clone();
    let mut u = DVector::zeros(0);
    for _ in 0..max_outer {
        let eta = rel * mean_diag;
        w.set_diagonal(&(p.w.diagonal().add_scalar(eta)));
        let q = p.q - &current * eta;
        let sub = Fc3d {
            w: &w,
            q: &q,
            mu: p.mu,
        };
        let mut trial = current.clone();
        pattern.velocity_into(&w, &trial, &q, &mut u);
        let inner = 0.01 * tolerance;
        let Some(it) = global_newton(&sub, pattern, &mut trial, &mut u, inner, 50, storage) else {
            // even a large shift fails from here: start again from the best iterate
            if rel >= 1.0 {
                rel = 1e-4;
                current.copy_from(r);
            } else {
                rel *= 10.0;
            }
            continue;
        };
        total += it + 1;
        let e = natural_map_error(p, &trial);
        current = trial;
        if e < best {
            best = e;
            r.copy_from(&current);
        }
        if e <= tolerance {
            return Some(total);
        }
        rel = (rel * 0.3).max(1e-7);
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    /// A solve reads nothing that an earlier one left in its storage: a chain of three
    /// frictional contacts (the first and the last uncoupled, so that the Jacobian has zero
    /// blocks) solves to the same bits, in as many iterations, in fresh storage and in
    /// storage that a larger problem, taken in another order, used before; and so does the
    /// chain with its middle contact numbered first, which the solve takes in another order.
    #[test]
    fn a_solve_reads_nothing_an_earlier_one_left() {
        let chain = |middle: usize| {
            DMatrix::from_fn(9, 9, move |i, j| {
                let base = if i == j { 2.0 + 0.1 * i as f64 } else { 0.0 };
                let (a, b) = (i / 3, j / 3);
                let linked = a != b && (a == middle || b == middle);
                base + if linked && (i + j) % 2 == 0 { 0.3 } else { 0.0 }
            })
        };
        let q = DVector::from_vec(vec![-1.0, 0.8, 0.1, -0.5, 0.0, 0.05, -0.7, -0.2, 0.3]);
        let mu = [0.3, 0.5, 0.4];
        let solve = |w: &DMatrix<f64>, storage: &mut NewtonStorage| {
            let p = Fc3d { w, q: &q, mu: &mu };
            let mut r = DVector::zeros(9);
            let mut u = q.clone();
            let it = global_newton(&p, &BlockPattern::of(w), &mut r, &mut u, 1e-12, 50, storage);
            (it, natural_map_error(&p, &r), r)
        };
        // storage used by a problem of four contacts whose hub, the first, goes last
        let mut used = NewtonStorage::default();
        let hub = DMatrix::from_fn(12, 12, |i, j| {
            let (a, b) = (i / 3, j / 3);
            match (i == j, a == b || a == 0 || b == 0) {
                (true, _) => 3.0,
                (false, true) => 0.2,
                (false, false) => 0.0,
            }
        });
        let q4 = DVector::from_fn(12, |i, _| if i % 3 == 0 { -1.0 } else { 0.3 });
        let p4 = Fc3d {
            w: &hub,
            q: &q4,
            mu: &[0.5; 4],
        };
        let mut r4 = DVector::zeros(12);
        let pattern = BlockPattern::of(&hub);
        let mut u4 = q4.clone();
        assert!(global_newton(&p4, &pattern, &mut r4, &mut u4, 1e-12, 50, &mut used).is_some());
        for middle in [1, 0] {
            let w = chain(middle);
            let mut order = Vec::new();
            BlockPattern::of(&w).minimum_degree_into(&mut order, &mut MinimumDegree::default());
            assert_eq!(order, [[1, 0, 2], [0, 1, 2]][middle], "the order taken");
            let (it, error, r) = solve(&w, &mut NewtonStorage::default());
            assert!(it.is_some() && error <= 1e-12, "{it:?} {error}");
            if middle == 1 {
                // the first contact slides: its friction is on the cone's boundary
                assert!(
                    (r[1].hypot(r[2]) - mu[0] * r[0]).abs() <= 1e-9 * r[0],
                    "{r}"
                );
            }
            let (it2, _, r2) = solve(&w, &mut used);
            assert_eq!(it, it2);
            assert_eq!(r, r2);
        }
    }

    /// A problem of the pattern solved last keeps that solve's factor storage, whose fill-in
    /// blocks the Jacobian does not write: a ring of four contacts (each coupled to its two
    /// neighbours, so that eliminating any one fills in a block) solves to the same bits
    /// after a ring of other numbers as in fresh storage.
    #[test]
    fn fill_in_is_cleared_between_solves() {
        let ring = |scale: f64| {
            DMatrix::from_fn(12, 12, move |i, j| {
                let (a, b) = (i / 3, j / 3);
                let neighbours = (a + 1) % 4 == b || (b + 1) % 4 == a;
                match (i == j, a == b || neighbours) {
                    (true, _) => 2.0 + 0.1 * i as f64,
                    (false, true) => scale * 0.3 / (1.0 + (i + j) as f64),
                    (false, false) => 0.0,
                }
            })
        };
        let q = DVector::from_fn(12, |i, _| if i % 3 == 0 { -1.0 } else { 0.4 });
        let mu = [0.3, 0.5, 0.4, 0.6];
        let solve = |w: &DMatrix<f64>, storage: &mut NewtonStorage| {
            let p = Fc3d { w, q: &q, mu: &mu };
            let mut r = DVector::zeros(12);
            let mut u = q.clone();
            let it = global_newton(&p, &BlockPattern::of(w), &mut r, &mut u, 1e-12, 50, storage);
            assert!(it.is_some());
            r
        };
        let fresh = solve(&ring(1.0), &mut NewtonStorage::default());
        let mut used = NewtonStorage::default();
        solve(&ring(-2.5), &mut used);
        assert_eq!(solve(&ring(1.0), &mut used), fresh);
    }

    /// The Jacobian formed in the factors' blocks is ∂Φ/∂r (finite differences of Φ, with
    /// u = W r + q, at a point where contacts stick, slide and are open), and the step
    /// solved through the factors is −J⁻¹Φ in the original numbering. W is an arrow:
    /// contact 0 is coupled to every other, and no other pair is.
    #[test]
    fn the_factored_jacobian_is_phis_derivative() {
        let n = 5;
        let w = DMatrix::from_fn(3 * n, 3 * n, |i, j| {
            let (a, b) = (i / 3, j / 3);
            if i == j {
                2.0 + 0.1 * i as f64
            } else if a == b || a == 0 || b == 0 {
                0.4 / (1.0 + (i + 2 * j) as f64)
            } else {
                0.0
            }
        });
        let pattern = BlockPattern::of(&w);
        let q = DVector::from_vec(vec![
            -0.5, 0.01, 0.0, // sticks
            -0.3, 2.0, -1.0, // slides
            3.0, 0.2, 0.1, // opens
            -0.2, 0.4, 0.9, // slides
            -1.0, 0.0, 0.02, // sticks
        ]);
        let r = DVector::from_fn(3 * n, |i, _| if i % 3 == 0 { 0.5 } else { 0.05 });
        let mu = [0.3, 0.5, 0.1, 0.8, 0.6];
        let p = Fc3d {
            w: &w,
            q: &q,
            mu: &mu,
        };
        let rho: Vec<(f64, f64)> = (0..n).map(|_| (0.5, 0.7)).collect();
        let phi_at = |r: &DVector<f64>| {
            let (mut u, mut phi) = (DVector::zeros(0), DVector::zeros(0));
            pattern.velocity_into(&w, r, &q, &mut u);
            phi_and_jacobian(&p, &pattern, r, &u, &rho, &mut phi, None);
            phi
        };
        let mut order = Vec::new();
        pattern.minimum_degree_into(&mut order, &mut MinimumDegree::default());
        assert_eq!(order, [1, 2, 3, 0, 4], "the hub with one spoke left");
        let mut position = vec![0; n];
        for (k, &a) in order.iter().enumerate() {
            position[a] = k;
        }
        let mut factors = BlockLu::default();
        factors.set_pattern(&pattern, &order);
        let (mut u, mut phi) = (DVector::zeros(0), DVector::zeros(0));
        pattern.velocity_into(&w, &r, &q, &mut u);
        let jac = Some((&mut factors, &position[..]));
        phi_and_jacobian(&p, &pattern, &r, &u, &rho, &mut phi, jac);
        let eps = 1e-6;
        let mut dense = DMatrix::zeros(3 * n, 3 * n);
        for j in 0..3 * n {
            let (mut up, mut down) = (r.clone(), r.clone());
            up[j] += eps;
            down[j] -= eps;
            dense.set_column(j, &((phi_at(&up) - phi_at(&down)) / (2.0 * eps)));
        }
        for a in 0..n {
            for b in 0..n {
                let fd = dense.fixed_view::<3, 3>(3 * a, 3 * b);
                if pattern.coupled(a, b) {
                    let formed = *factors.block_mut(position[a], position[b]);
                    assert!(
                        (formed - fd).amax() < 1e-8,
                        "block ({a}, {b}): {formed} {fd}"
                    );
                } else {
                    assert_eq!(fd.amax(), 0.0, "block ({a}, {b}) outside the pattern");
                }
            }
        }
        assert!(dense.amax() > 0.1);
        let expected = -dense.clone().lu().solve(&phi).expect("regular");
        assert!(factors.factorise(0.0));
        let mut step: Vec<f64> = order
            .iter()
            .flat_map(|&a| [-phi[3 * a], -phi[3 * a + 1], -phi[3 * a + 2]])
            .collect();
        factors.solve_in_place(&mut step);
        for (k, &a) in order.iter().enumerate() {
            for c in 0..3 {
                let e = expected[3 * a + c];
                assert!((step[3 * k + c] - e).abs() < 1e-5 * expected.amax(), "{a}");
            }
        }
    }
}
