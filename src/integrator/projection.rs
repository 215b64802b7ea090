//! Position projection onto the constraint manifolds (`moreau_jean.md` §4), in twist
//! coordinates with the mass metric: with C the gradients of the projected rows,
//! solve (C M⁻¹ Cᵀ) Λ = −c(q) (equality rows; complementarity for contacts in direct
//! projection), Δν = M⁻¹ Cᵀ Λ and q ← q ⊕ Δν through the Lie-group update, so |p| = 1
//! holds by construction. Iterated (Gauss–Newton) until the violation is below tolerance.
//! Velocities are not touched.

use super::moreau_jean::bilateral_matrix;
use crate::mechanics::joint::{BilateralRow, RowUnit};
use crate::mechanics::{Model, Pose};
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

/// Rows and violations of the constraints at `poses`: the joint rows, then the contacts'.
struct Evaluated {
    rows: Vec<BilateralRow>,
    njoint: usize,
    /// Largest violation (the convergence test) and the sum of squares (the merit).
    max: f64,
    squares: f64,
}

fn evaluate_rows(
    model: &Model,
    t: f64,
    poses: &[Pose],
    contact_rows: &dyn Fn(&[Pose]) -> Vec<BilateralRow>,
    mode: ContactRows,
) -> Evaluated {
    let mut rows = Vec::new();
    for j in &model.joints {
        j.rows(t, poses, &mut rows);
    }
    let njoint = rows.len();
    rows.extend(contact_rows(poses));
    let (mut max, mut squares) = (0.0f64, 0.0);
    for (k, r) in rows.iter().enumerate() {
        let v = if k >= njoint && mode == ContactRows::Inequality {
            (-r.value).max(0.0)
        } else {
            r.value.abs()
        };
        max = max.max(v);
        squares += v * v;
    }
    Evaluated {
        rows,
        njoint,
        max,
        squares,
    }
}

/// Step halvings tried before an iteration gives up.
const MAX_HALVINGS: usize = 8;

/// Projects `poses` at time `t`. `contact_rows(poses)` returns the gap and the gradient
/// blocks of the contacts to project, evaluated at the given poses.
///
/// Damped Gauss–Newton: the full step is taken when it lowers the squared violation,
/// else it is halved (up to `MAX_HALVINGS` times). Where the constraint manifold is
/// curved on the scale of the correction (a ring contact at a clearance of nanometres,
/// a journal that crossed its clearance in one large step) the full step overshoots and
/// the undamped iteration wanders off; the damped one never leaves the poses worse
/// than it found them.
#[allow(clippy::too_many_arguments)]
pub fn project(
    model: &Model,
    mask: &[bool],
    minv: &[Matrix6<f64>],
    t: f64,
    poses: &mut [Pose],
    contact_rows: &dyn Fn(&[Pose]) -> Vec<BilateralRow>,
    mode: ContactRows,
    tolerance: f64,
    max_iterations: usize,
) -> ProjectionOutcome {
    let ndof = 6 * model.bodies.len();
    let mut current = evaluate_rows(model, t, poses, contact_rows, mode);
    let mut out = ProjectionOutcome {
        violation_before: current.max,
        violation_after: current.max,
        ..Default::default()
    };
    let mut trial_poses = poses.to_vec();
    for it in 0..=max_iterations {
        out.iterations = it;
        out.violation_after = current.max;
        if current.max <= tolerance {
            out.converged = true;
            return out;
        }
        if it == max_iterations || current.rows.is_empty() {
            break;
        }
        let rows = &current.rows;
        let njoint = current.njoint;
        let (cmat, _) = bilateral_matrix(rows, mask, ndof);
        // M⁻¹ Cᵀ, body block by body block
        let mut mct = DMatrix::zeros(ndof, rows.len());
        for (b, mi) in minv.iter().enumerate() {
            let blk = mi * cmat.columns(6 * b, 6).transpose();
            mct.rows_mut(6 * b, 6).copy_from(&blk);
        }
        let a = &cmat * &mct;
        let c = DVector::from_iterator(rows.len(), rows.iter().map(|r| r.value));
        let lambda = match mode {
            ContactRows::Inequality if rows.len() > njoint => {
                // inequality rows: 0 ≤ w = c + A Λ ⟂ Λ ≥ 0 (pushes out only)
                let equality: Vec<bool> = (0..rows.len()).map(|k| k < njoint).collect();
                let mut z = DVector::zeros(rows.len());
                solve_mixed_pgs(&a, &c, &equality, &mut z, 0.1 * tolerance, 10_000);
                z
            }
            _ => EqualitySolver::new(a).solve(&(-&c)),
        };
        let dnu = &mct * lambda;
        if dnu.iter().any(|x| !x.is_finite()) {
            break;
        }
        let mut accepted = None;
        let mut alpha = 1.0;
        for _ in 0..=MAX_HALVINGS {
            for (b, (trial, pose)) in trial_poses.iter_mut().zip(poses.iter()).enumerate() {
                let d = alpha * Vector6::from_column_slice(&dnu.as_slice()[6 * b..6 * b + 6]);
                *trial = if d != Vector6::zeros() {
                    pose.advanced(&d)
                } else {
                    *pose
                };
            }
            let e = evaluate_rows(model, t, &trial_poses, contact_rows, mode);
            if e.squares < current.squares {
                accepted = Some(e);
                break;
            }
            alpha *= 0.5;
        }
        let Some(next) = accepted else { break };
        poses.copy_from_slice(&trial_poses);
        current = next;
    }
    out
}

/// Normal rows (gap and its gradient) of contact points, as bilateral rows.
pub fn contact_normal_row(cp: &crate::mechanics::ContactPoint) -> BilateralRow {
    let row = |g: &nalgebra::Matrix3x6<f64>| -> RowVector6<f64> { g.row(0).into_owned() };
    BilateralRow {
        a: cp.body1.map(|i| (i, row(&cp.g1))),
        b: cp.body2.map(|i| (i, row(&cp.g2))),
        value: cp.gap(),
        rate: 0.0,
        unit: RowUnit::Length,
    }
}
