//! FC3D(W, q, μ): find u, r ∈ R^{3n} with u = W r + q and, per contact,
//! K* ∋ û ⟂ r ∈ K, where K = {‖r_T‖ ≤ μ r_N} and û = u + (μ‖u_T‖, 0, 0)
//! Components are ordered (N, T1, T2) per contact.

use crate::math::blocks::vector3;
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

/// A problem instance (borrowed).
#[derive(Clone, Copy, Debug)]
pub struct Fc3d<'a> {
    pub w: &'a DMatrix<f64>,
    pub q: &'a DVector<f64>,
    pub mu: &'a [f64],
}

/// Outcome of a solve: a step that did not converge must be reported, never accepted
/// silently.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolverStatus {
    pub converged: bool,
    /// Gauss–Seidel sweeps and global Newton iterations used.
    pub iterations: usize,
    /// Relative natural-map error at exit (see [`natural_map_error`]).
    pub residual: f64,
}

/// Projection onto the Coulomb cone K_μ (closed form).
#[inline]
pub fn project_on_cone(r: &Vector3<f64>, mu: f64) -> Vector3<f64> {
    let t = (r.y * r.y + r.z * r.z).sqrt();
    if mu * t <= -r.x {
        Vector3::zeros()
    } else if t <= mu * r.x {
        *r
    } else {
        let rn = (mu * t + r.x) / (1.0 + mu * mu);
        if t > 0.0 {
            Vector3::new(rn, mu * rn * r.y / t, mu * rn * r.z / t)
        } else {
            Vector3::new(rn, 0.0, 0.0)
        }
    }
}

/// Natural-map residual of one contact, `r − P_K(r − ρ û)`, with ρ converting the
/// velocity into impulse units.
#[inline]
pub fn local_natural_map(r: &Vector3<f64>, u: &Vector3<f64>, mu: f64, rho: f64) -> Vector3<f64> {
    let ut = (u.y * u.y + u.z * u.z).sqrt();
    let uhat = Vector3::new(u.x + mu * ut, u.y, u.z);
    r - project_on_cone(&(r - uhat * rho), mu)
}

/// Step ρ_α = 3 / trace(W_αα) that makes ρ u an impulse.
#[inline]
pub fn contact_rho(block: &Matrix3<f64>) -> f64 {
    rho_of_trace(block.trace())
}

/// `contact_rho` of contact a's diagonal block of `w`, read in place.
#[inline]
fn contact_rho_in(w: &DMatrix<f64>, a: usize) -> f64 {
    let o = 3 * a;
    rho_of_trace(w[(o, o)] + w[(o + 1, o + 1)] + w[(o + 2, o + 2)])
}

/// 3 / `trace`, or 1 for a block without a positive trace.
#[inline]
fn rho_of_trace(trace: f64) -> f64 {
    if trace > 0.0 {
        3.0 / trace
    } else {
        1.0
    }
}

/// Relative natural-map error: √(Σ_α ‖r_α − P_K(r_α − ρ_α û_α)‖²) divided by
/// max(‖r‖, ‖ρ q‖). Zero exactly at a solution; dimensionless and invariant to the units of
/// impulse and velocity.
pub fn natural_map_error(p: &Fc3d, r: &DVector<f64>) -> f64 {
    natural_map_error_at(p, r, &(p.w * r + p.q))
}

/// [`natural_map_error`] given u = W r + q (which a solver that knows W's sparsity computes
/// faster).
pub fn natural_map_error_at(p: &Fc3d, r: &DVector<f64>, u: &DVector<f64>) -> f64 {
    let mut num = 0.0;
    let mut rq = 0.0;
    for (a, &mu) in p.mu.iter().enumerate() {
        let o = 3 * a;
        let rho = contact_rho_in(p.w, a);
        num += local_natural_map(&vector3(r, o), &vector3(u, o), mu, rho).norm_squared();
        rq += rho * rho * (p.q[o] * p.q[o] + p.q[o + 1] * p.q[o + 1] + p.q[o + 2] * p.q[o + 2]);
    }
    let scale = r.norm().max(rq.sqrt());
    if num == 0.0 {
        0.0
    } else {
        num.sqrt() / scale.max(f64::MIN_POSITIVE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn cone_projection_cases() {
        let mu = 0.5;
        // inside: unchanged
        let r = Vector3::new(1.0, 0.3, -0.2);
        assert_eq!(project_on_cone(&r, mu), r);
        // polar cone: zero
        assert_eq!(
            project_on_cone(&Vector3::new(-1.0, 0.1, 0.0), mu),
            Vector3::zeros()
        );
        // outside: lands on the boundary and the difference is normal to the cone there
        let r = Vector3::new(1.0, 2.0, 1.0);
        let p = project_on_cone(&r, mu);
        assert_relative_eq!((p.y * p.y + p.z * p.z).sqrt(), mu * p.x, epsilon = 1e-14);
        let d = r - p;
        assert!(
            d.dot(&p).abs() < 1e-14,
            "projection residual orthogonal to the projection"
        );
        // idempotent
        assert_relative_eq!(project_on_cone(&p, mu), p, epsilon = 1e-15);
        // μ = 0: the cone is the positive normal half-line
        assert_eq!(
            project_on_cone(&Vector3::new(2.0, 1.0, 1.0), 0.0),
            Vector3::new(2.0, 0.0, 0.0)
        );
    }
}
