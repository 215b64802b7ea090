//! Rotation helpers on top of nalgebra: the skew operator, the quaternion exponential map
//! and the deterministic tangent basis of a contact normal; (`buffer`) vectors resized in
//! place, for storage reused from one step to the next; (`sized`) loops specialised to the
//! small sizes of joint and contact systems; and (`blocks`) the 3- and 6-vectors and 3×3
//! blocks of slices, dynamic vectors and matrices, read by index.
//!
//! Quaternions stay nalgebra's `UnitQuaternion`; nothing here multiplies quaternion
//! components by hand except the exponential map itself, which needs a series near zero.

pub mod blocks;
pub mod buffer;
pub mod sized;

use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

/// `skew(a) * b == a × b`.
#[inline]
pub fn skew(a: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// Exponential map of the unit quaternions: the rotation by the rotation vector `phi`,
/// `expq(φ) = (cos(θ/2), sin(θ/2)/θ · φ)` with θ = |φ|. Uses the series of sin(θ/2)/θ
/// near zero so that tiny increments lose no digits. The result is unit to round-off, and
/// no renormalisation is applied (docs/method.md).
#[inline]
pub fn expq(phi: &Vector3<f64>) -> UnitQuaternion<f64> {
    let th2 = phi.norm_squared();
    let th = th2.sqrt();
    let (c, s_over_th) = if th < 1e-4 {
        // cos(θ/2) = 1 − θ²/8 + θ⁴/384; sin(θ/2)/θ = 1/2 − θ²/48 + θ⁴/3840
        (
            1.0 - th2 / 8.0 + th2 * th2 / 384.0,
            0.5 - th2 / 48.0 + th2 * th2 / 3840.0,
        )
    } else {
        ((0.5 * th).cos(), (0.5 * th).sin() / th)
    };
    UnitQuaternion::new_unchecked(Quaternion::new(
        c,
        s_over_th * phi.x,
        s_over_th * phi.y,
        s_over_th * phi.z,
    ))
}

/// Right composition `p ⊗ expq(φ)`: the Lie-group update with a body-frame rotation
/// vector. nalgebra's product of unit quaternions does not renormalise, so |p| − 1 shows
/// the true round-off of the scheme.
#[inline]
pub fn compose_body(p: &UnitQuaternion<f64>, phi: &Vector3<f64>) -> UnitQuaternion<f64> {
    p * expq(phi)
}

/// Orthonormal tangent vectors `(t1, t2)` completing the unit normal `n` to a right-handed
/// frame (n, t1, t2), by the branchless construction of Frisvad revised by Duff et al.
/// (2017). Deterministic, so results are reproducible bit for bit.
#[inline]
pub fn tangent_basis(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let s = 1.0_f64.copysign(n.z);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    let t1 = Vector3::new(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    let t2 = Vector3::new(b, s + n.y * n.y * a, -n.y);
    (t1, t2)
}

/// Piecewise-linear interpolation in a table of strictly increasing times, clamped to the
/// first and last values outside it.
pub fn piecewise_linear<T>(rows: &[(f64, T)], t: f64) -> T
where
    T: Copy
        + std::ops::Add<Output = T>
        + std::ops::Sub<Output = T>
        + std::ops::Mul<f64, Output = T>,
{
    let i = rows.partition_point(|(ti, _)| *ti <= t);
    if i == 0 {
        rows[0].1
    } else if i == rows.len() {
        rows[i - 1].1
    } else {
        let (t0, v0) = rows[i - 1];
        let (t1, v1) = rows[i];
        v0 + (v1 - v0) * ((t - t0) / (t1 - t0))
    }
}

/// Any unit vector orthogonal to the unit vector `n` (deterministic).
#[inline]
pub fn any_orthogonal(n: &Vector3<f64>) -> Vector3<f64> {
    tangent_basis(n).0
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn expq_matches_axis_angle_and_series_is_continuous() {
        for &angle in &[1e-12, 1e-6, 9.9e-5, 1.01e-4, 0.3, 2.0, 3.1] {
            let axis = Vector3::new(0.3, -0.5, 0.8).normalize();
            let q = expq(&(axis * angle));
            let r = UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle);
            assert!(q.angle_to(&r) < 1e-15, "angle {angle}");
            assert!((q.quaternion().norm() - 1.0).abs() < 2e-16);
        }
    }

    #[test]
    fn tangent_basis_is_right_handed_orthonormal() {
        for n in [
            Vector3::new(0.0, 0.0, 1.0),
            Vector3::new(0.0, 0.0, -1.0),
            Vector3::new(1.0, 2.0, -3.0).normalize(),
            Vector3::new(1.0, 0.0, 0.0),
        ] {
            let (t1, t2) = tangent_basis(&n);
            assert_relative_eq!(t1.norm(), 1.0, epsilon = 1e-15);
            assert_relative_eq!(t2.norm(), 1.0, epsilon = 1e-15);
            assert!(
                n.dot(&t1).abs() < 1e-15 && n.dot(&t2).abs() < 1e-15 && t1.dot(&t2).abs() < 1e-15
            );
            assert_relative_eq!(n.cross(&t1), t2, epsilon = 1e-15);
        }
    }

    #[test]
    fn skew_is_cross_product() {
        let a = Vector3::new(1.0, -2.0, 0.5);
        let b = Vector3::new(0.3, 0.7, -1.1);
        assert_relative_eq!(skew(&a) * b, a.cross(&b), epsilon = 1e-15);
    }
}
