//! Compliant contact (docs/compliant-contact.md): beside the rigid law (Signorini, Newton's
//! impacts), a contact can carry a smooth force of its penetration δ = −g and rate δ̇,
//!
//! F_N = K δⁿ (1 + D δ̇),  never below zero,
//!
//! with K and n from Hertz's theory (sphere on a plane, sphere on a sphere; a journal in its
//! bore as Lankarani and Nikravesh's equivalent sphere) or given, and D chosen so that a free
//! impact at speed v₀ restitutes e (Hunt–Crossley 1975: D = 3(1 − e)/(2 v₀), for e near 1;
//! Flores et al. 2011: D = 8(1 − e)/(5 e v₀), over the whole range; or D solved for so
//! that the law's own free impact restitutes e exactly). Friction is Coulomb's,
//! regularised: F_T = −μ F_N u_T / √(|u_T|² + v_ε²), a smooth force that the θ-scheme's
//! Newton loop can differentiate; below the slip speed v_ε a "stuck" contact creeps at
//! |u_T| ≈ v_ε |F_T| / (μ F_N).

use super::clearance::ClearanceJoint;
use super::{ContactPair, ContactPoint};
use crate::mechanics::body::Pose;
use nalgebra::{Matrix3, Matrix6, Vector3};
use std::collections::BTreeMap;
use std::sync::{Mutex, MutexGuard};

/// The impact speed a contact is taken to have closed at when it closed slower (m/s): a
/// contact pressed on slowly (a clamp closing, a part settling) then has the damping of an
/// impact at this speed, which settles it without ringing, and its static force K δⁿ does
/// not depend on it.
pub const RESTING_SPEED: f64 = 1e-3;

/// How the dissipation coefficient D follows from the restitution e and the impact speed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Dissipation {
    /// D = χ / v₀ with χ solved for (`Dissipation::matched`) so that a free impact of the
    /// law restitutes e exactly, at any e in (0, 1].
    Matched(f64),
    /// D = 3(1 − e)/(2 v₀) (Hunt and Crossley 1975): exact as e → 1, too little damping
    /// below about e = 0.7.
    HuntCrossley,
    /// D = 8(1 − e)/(5 e v₀) (Flores, Machado, Silva and Martins 2011): a closed form over
    /// the whole range, within 6 % of the requested e at e = 0.5; needs e > 0.
    Flores,
}

impl Dissipation {
    /// The dissipation of `Matched`: a free impact under K δⁿ (1 + D δ̇) is, in units of
    /// its own length and time, x'' = −xⁿ (1 + χ x') from x = 0, x' = 1, and leaves at
    /// −x' = e(χ, n) whatever the mass, stiffness and speed; e falls with χ, which is
    /// found by bisection on that motion (integrated by RK4).
    ///
    /// A study builds its scene anew for every sample, with the same e and n unless they
    /// are sampled: each pair is solved once in a process (a solve takes about 10 ms) and
    /// remembered, which changes no result.
    pub fn matched(e: f64, n: f64) -> Dissipation {
        let key = (e.to_bits(), n.to_bits());
        if let Some(&chi) = solved_chis().get(&key) {
            return Dissipation::Matched(chi);
        }
        let chi = matched_chi(e, n);
        solved_chis().insert(key, chi);
        Dissipation::Matched(chi)
    }
}

/// The χ of every (e, n) solved so far in this process, by their bits.
fn solved_chis() -> MutexGuard<'static, BTreeMap<(u64, u64), f64>> {
    static SOLVED: Mutex<BTreeMap<(u64, u64), f64>> = Mutex::new(BTreeMap::new());
    SOLVED
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// χ of `Dissipation::matched`, by bisection.
fn matched_chi(e: f64, n: f64) -> f64 {
    if e >= 1.0 {
        return 0.0;
    }
    // e ≤ 0 needs an infinite χ: the bracket stops growing at 1e12
    let (mut lo, mut hi) = (0.0, 1.0);
    while rebound(hi, n) > e && hi < 1e12 {
        hi *= 2.0;
    }
    for _ in 0..45 {
        let mid = 0.5 * (lo + hi);
        if rebound(mid, n) > e {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The speed −x' at which x'' = −xⁿ max(0, 1 + χ x') returns to x = 0 from x = 0, x' = 1.
fn rebound(chi: f64, n: f64) -> f64 {
    let accel = |x: f64, u: f64| -x.max(0.0).powf(n) * (1.0 + chi * u).max(0.0);
    let dt = 2e-3;
    let (mut x, mut u) = (0.0_f64, 1.0_f64);
    // it leaves no slower than 1/χ, the speed below which the force vanishes
    for _ in 0..100_000_000 {
        let (k1x, k1u) = (u, accel(x, u));
        let (k2x, k2u) = (
            u + 0.5 * dt * k1u,
            accel(x + 0.5 * dt * k1x, u + 0.5 * dt * k1u),
        );
        let (k3x, k3u) = (
            u + 0.5 * dt * k2u,
            accel(x + 0.5 * dt * k2x, u + 0.5 * dt * k2u),
        );
        let (k4x, k4u) = (u + dt * k3u, accel(x + dt * k3x, u + dt * k3u));
        let (x1, u1) = (
            x + dt / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x),
            u + dt / 6.0 * (k1u + 2.0 * k2u + 2.0 * k3u + k4u),
        );
        if x1 < 0.0 {
            // the speed where x crosses 0, between the two states
            let s = x / (x - x1);
            return -(u + s * (u1 - u));
        }
        (x, u) = (x1, u1);
    }
    0.0
}

/// The force law of a compliant contact point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompliantLaw {
    /// K (N/mⁿ).
    pub stiffness: f64,
    /// n (1.5 for Hertz).
    pub exponent: f64,
    /// The restitution coefficient e of a free impact, in (0, 1].
    pub restitution: f64,
    pub dissipation: Dissipation,
    /// Coulomb coefficient μ.
    pub mu: f64,
    /// v_ε of the regularised friction (m/s).
    pub slip_speed: f64,
}

/// 1/E* = (1 − ν₁²)/E₁ + (1 − ν₂²)/E₂: the contact modulus of two elastic bodies.
pub fn contact_modulus(e1: f64, nu1: f64, e2: f64, nu2: f64) -> f64 {
    1.0 / ((1.0 - nu1 * nu1) / e1 + (1.0 - nu2 * nu2) / e2)
}

/// Hertz's K = (4/3) E* √R for two bodies whose curvatures add up to 1/R (n = 3/2).
pub fn hertz_stiffness(modulus: f64, radius: f64) -> f64 {
    4.0 / 3.0 * modulus * radius.sqrt()
}

impl CompliantLaw {
    /// D for an impact at `onset` speed (m/s, floored at `RESTING_SPEED`).
    pub fn damping(&self, onset: f64) -> f64 {
        let (e, v0) = (self.restitution, onset.max(RESTING_SPEED));
        match self.dissipation {
            Dissipation::Matched(chi) => chi / v0,
            Dissipation::HuntCrossley => 3.0 * (1.0 - e) / (2.0 * v0),
            Dissipation::Flores => 8.0 * (1.0 - e) / (5.0 * e * v0),
        }
    }

    /// F_N at penetration `depth` (m) growing at `rate` (m/s), for a contact that closed at
    /// `onset` speed: K δⁿ (1 + D δ̇), zero when open and never pulling.
    pub fn normal_force(&self, depth: f64, rate: f64, onset: f64) -> f64 {
        if depth <= 0.0 {
            return 0.0;
        }
        let elastic = self.stiffness * depth.powf(self.exponent);
        (elastic * (1.0 + self.damping(onset) * rate)).max(0.0)
    }

    /// The derivatives of `local_force` against the local velocity u (3×3) and the
    /// penetration δ (3), both zero where the point is open or its force vanishes.
    fn local_derivatives(
        &self,
        point: &ContactPoint,
        v: &[f64],
        onset: Option<f64>,
    ) -> (Matrix3<f64>, Vector3<f64>) {
        let depth = -point.gap();
        let u = point.local_velocity(v);
        let rate = -u.x;
        let d = self.damping(onset.unwrap_or(rate));
        let normal = self.normal_force(depth, rate, onset.unwrap_or(rate));
        if normal <= 0.0 {
            return (Matrix3::zeros(), Vector3::zeros());
        }
        let elastic = self.stiffness * depth.powf(self.exponent);
        // ∂F_N/∂u_N = −K δⁿ D; ∂F_N/∂δ = n K δⁿ⁻¹ (1 + D δ̇)
        let dn_du = -elastic * d;
        let dn_dd = self.exponent * elastic / depth * (1.0 + d * rate);
        let slip = (u.y * u.y + u.z * u.z + self.slip_speed * self.slip_speed).sqrt();
        let ut = nalgebra::Vector2::new(u.y, u.z);
        // F_T = −μ F_N u_T / s: against u_T, −μ F_N (I − u_T u_Tᵀ / s²) / s
        let dt_dt = (nalgebra::Matrix2::identity() - ut * ut.transpose() / (slip * slip))
            * (-self.mu * normal / slip);
        let along = -ut * (self.mu / slip);
        let mut du = Matrix3::zeros();
        du[(0, 0)] = dn_du;
        du[(1, 0)] = along.x * dn_du;
        du[(2, 0)] = along.y * dn_du;
        du.fixed_view_mut::<2, 2>(1, 1).copy_from(&dt_dt);
        let dd = Vector3::new(dn_dd, along.x * dn_dd, along.y * dn_dd);
        (du, dd)
    }

    /// The force on body 1 at `point` in its local frame (n, t1, t2), for the body twists
    /// `v`; `onset` is the speed the contact closed at, `None` while it closes (then the
    /// approach speed now stands for it).
    pub fn local_force(&self, point: &ContactPoint, v: &[f64], onset: Option<f64>) -> Vector3<f64> {
        let depth = -point.gap();
        if depth <= 0.0 {
            return Vector3::zeros();
        }
        let u = point.local_velocity(v);
        let rate = -u.x;
        let normal = self.normal_force(depth, rate, onset.unwrap_or(rate));
        let slip = (u.y * u.y + u.z * u.z + self.slip_speed * self.slip_speed).sqrt();
        let friction = -self.mu * normal / slip;
        Vector3::new(normal, friction * u.y, friction * u.z)
    }
}

/// Where a compliant contact's points come from.
#[derive(Clone, Debug, PartialEq)]
pub enum CompliantSource {
    /// Every candidate point of a contact pair.
    Pair(ContactPair),
    /// The two end rings of a clearance joint's bore against its journal, each with half
    /// the joint's stiffness; its flanges stay rigid contacts of the joint.
    Journal(ClearanceJoint),
}

/// A contact pair or a clearance joint under a compliant law.
#[derive(Clone, Debug, PartialEq)]
pub struct CompliantContact {
    pub source: CompliantSource,
    /// The law of one point (a journal's ring takes half its stiffness).
    pub law: CompliantLaw,
}

impl CompliantContact {
    pub fn name(&self) -> &str {
        match &self.source {
            CompliantSource::Pair(p) => &p.name,
            CompliantSource::Journal(j) => &j.name,
        }
    }

    /// Its points: a pair's candidates, a journal's two rings.
    pub fn points(&self) -> usize {
        match &self.source {
            CompliantSource::Pair(p) => p.candidates(),
            CompliantSource::Journal(_) => 2,
        }
    }

    /// Point `k` at `poses`.
    pub fn evaluate(&self, k: usize, poses: &[Pose]) -> ContactPoint {
        match &self.source {
            CompliantSource::Pair(p) => p.evaluate(k, poses),
            CompliantSource::Journal(j) => j.evaluate(k, poses),
        }
    }

    /// The law of one point.
    pub fn point_law(&self) -> CompliantLaw {
        match self.source {
            CompliantSource::Pair(_) => self.law,
            CompliantSource::Journal(_) => CompliantLaw {
                stiffness: 0.5 * self.law.stiffness,
                ..self.law
            },
        }
    }

    /// The elastic energy stored at `poses`: Σ K δⁿ⁺¹/(n + 1) over its points.
    pub fn potential(&self, poses: &[Pose]) -> f64 {
        let law = self.point_law();
        (0..self.points())
            .map(|k| (-self.evaluate(k, poses).gap()).max(0.0))
            .map(|d| law.stiffness * d.powf(law.exponent + 1.0) / (law.exponent + 1.0))
            .sum()
    }

    /// Adds the generalized force of its points at (`poses`, `v`) to `out` (6 per body),
    /// with `onset` the closing speed of each point (`None` while it closes).
    pub fn apply(&self, poses: &[Pose], v: &[f64], onset: &[Option<f64>], out: &mut [f64]) {
        let law = self.point_law();
        for (k, &o) in onset.iter().enumerate().take(self.points()) {
            let point = self.evaluate(k, poses);
            let f = law.local_force(&point, v, o);
            if f.x > 0.0 {
                point.add_generalized(&f, out);
            }
        }
    }

    /// The blocks (body x, body y, B) of its generalized force's Jacobian, weighted:
    /// B = w_q ∂f_x/∂q_y + w_v ∂f_x/∂v_y, with f_x = G_xᵀ P(δ, u), u = Σ G_y v_y and
    /// ∂δ/∂q_y = −N_y (the gap's gradient). The turn of the frame and the arms with the
    /// pose is left out: the Newton loop checks its residual, and the derivative of the
    /// force's magnitude, K n δⁿ⁻¹, is what makes the contact stiff.
    pub fn jacobian(
        &self,
        poses: &[Pose],
        v: &[f64],
        onset: &[Option<f64>],
        (w_q, w_v): (f64, f64),
        out: &mut Vec<(usize, usize, Matrix6<f64>)>,
    ) {
        let law = self.point_law();
        for (k, &o) in onset.iter().enumerate().take(self.points()) {
            let point = self.evaluate(k, poses);
            if point.gap() >= 0.0 {
                continue;
            }
            let (du, dd) = law.local_derivatives(&point, v, o);
            if dd == Vector3::zeros() {
                continue;
            }
            let (n1, n2) = point.normal_rows();
            let sides = [(point.body1, 0, n1), (point.body2, 1, n2)];
            for &(x, sx, _) in &sides {
                let Some(x) = x else { continue };
                let gx = point.block(sx);
                for &(y, sy, ny) in &sides {
                    let Some(y) = y else { continue };
                    let gy = point.block(sy);
                    let b = gx.transpose() * (du * gy * w_v - dd * ny * w_q);
                    out.push((x, y, b));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn law(e: f64, dissipation: Dissipation) -> CompliantLaw {
        CompliantLaw {
            stiffness: 1e10,
            exponent: 1.5,
            restitution: e,
            dissipation,
            mu: 0.0,
            slip_speed: 1e-4,
        }
    }

    /// Steel on steel: E* = E / (2 (1 − ν²)); a 10 mm sphere gives K = 4/3 E* √R.
    #[test]
    fn hertz_stiffness_of_steel_spheres() {
        let m = contact_modulus(210e9, 0.3, 210e9, 0.3);
        assert!((m - 210e9 / (2.0 * 0.91)).abs() < 1.0);
        let k = hertz_stiffness(m, 0.01);
        assert!((k - 4.0 / 3.0 * m * 0.1).abs() < 1e-3 * k);
    }

    /// The force is elastic when the rate is zero, grows with the approach, never pulls,
    /// and vanishes when open.
    #[test]
    fn the_normal_force_is_elastic_at_rest_and_never_pulls() {
        let l = law(0.8, Dissipation::Flores);
        let d: f64 = 1e-5;
        let elastic = 1e10 * d.powf(1.5);
        assert!((l.normal_force(d, 0.0, 1.0) - elastic).abs() < 1e-9 * elastic);
        let d_coeff = 8.0 * 0.2 / (5.0 * 0.8 * 1.0);
        let loading = l.normal_force(d, 0.5, 1.0);
        assert!((loading - elastic * (1.0 + d_coeff * 0.5)).abs() < 1e-9 * elastic);
        assert_eq!(l.normal_force(d, -10.0, 1.0), 0.0);
        assert_eq!(l.normal_force(-d, 1.0, 1.0), 0.0);
        let hc = law(0.8, Dissipation::HuntCrossley);
        assert!((hc.damping(2.0) - 3.0 * 0.2 / 4.0).abs() < 1e-15);
        // slow closings take the damping of an impact at the resting speed
        assert_eq!(hc.damping(0.0), hc.damping(RESTING_SPEED));
    }
}
