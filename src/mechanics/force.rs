//! Applied forces besides gravity: point-to-point springs/dampers, torsional springs and
//! prescribed external loads. Each element adds its generalized wrench (force in the
//! inertial frame, torque in the body frame) to the bodies it acts on, and reports its
//! potential energy where it has one.

use super::body::{point_velocity, pose_of, BodyRef, Pose, Twist};
use crate::math::blocks::vector6_at;
use crate::math::{any_orthogonal, skew};
use nalgebra::{Matrix3, Vector3};

/// A block of a force element's Jacobian: (body x, body y, ∂τ_x/∂(δ or ω)_y), the
/// body-frame torque on x against a body-frame rotation increment or angular velocity of y.
pub type RotationBlock = (usize, usize, Matrix3<f64>);

/// A load vector in time: constant, or a piecewise-linear function of time (clamped at
/// both ends).
#[derive(Clone, Debug, PartialEq)]
pub enum LoadProfile {
    Constant(Vector3<f64>),
    /// Strictly increasing times with the value at each.
    Table(Vec<(f64, Vector3<f64>)>),
}

impl LoadProfile {
    pub fn at(&self, t: f64) -> Vector3<f64> {
        match self {
            LoadProfile::Constant(v) => *v,
            LoadProfile::Table(rows) => crate::math::piecewise_linear(rows, t),
        }
    }

    /// A table's times, where the load's rate jumps.
    pub fn knots(&self) -> Vec<f64> {
        match self {
            LoadProfile::Constant(_) => Vec::new(),
            LoadProfile::Table(rows) => rows.iter().map(|r| r.0).collect(),
        }
    }
}

/// In which frame a prescribed vector is expressed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Frame {
    #[default]
    World,
    Body,
}

/// Tension `T = preload + k (l − rest_length) + c l̇` along the line between two body
/// points: it pulls the points together when positive.
#[derive(Clone, Debug, PartialEq)]
pub struct PointSpring {
    pub a: BodyRef,
    pub point_a: Vector3<f64>,
    pub b: BodyRef,
    pub point_b: Vector3<f64>,
    pub stiffness: f64,
    pub damping: f64,
    pub rest_length: f64,
    pub preload: f64,
    /// Time over which the preload rises linearly from zero (0: applied at once).
    pub ramp: f64,
}

/// A preload applied over `ramp` seconds from t = 0: assembling a preloaded mechanism
/// gradually lets its journals settle into their bores quasi-statically instead of by
/// impacts, so the settled state depends on the physics rather than on the step size.
fn ramped(preload: f64, ramp: f64, t: f64) -> f64 {
    if ramp > 0.0 {
        preload * (t / ramp).clamp(0.0, 1.0)
    } else {
        preload
    }
}

/// Moment `M = preload + k (φ − rest_angle) + c φ̇` about an axis fixed in body `a`, where
/// φ is the rotation of body `b` relative to `a` about that axis, measured from the
/// configuration in which the spring was built. It acts on `b` as −M and on `a` as +M.
#[derive(Clone, Debug, PartialEq)]
pub struct TorsionalSpring {
    pub a: BodyRef,
    pub b: BodyRef,
    /// Unit axis in body a's frame.
    pub axis_a: Vector3<f64>,
    /// Zero-angle reference directions, in each body's frame (set by [`TorsionalSpring::new`]).
    ref_a: Vector3<f64>,
    ref_b: Vector3<f64>,
    pub stiffness: f64,
    pub damping: f64,
    pub preload: f64,
    pub rest_angle: f64,
    /// Time over which the preload rises linearly from zero (0: applied at once).
    pub ramp: f64,
}

/// A prescribed force at a body point and/or a prescribed torque.
#[derive(Clone, Debug, PartialEq)]
pub struct ExternalLoad {
    pub body: usize,
    /// Point of application in body coordinates.
    pub point: Vector3<f64>,
    pub force: Option<LoadProfile>,
    pub torque: Option<LoadProfile>,
    pub frame: Frame,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Force {
    Spring(PointSpring),
    Torsional(TorsionalSpring),
    External(ExternalLoad),
}

impl Force {
    /// The instants at which the force's rate in time jumps: its tables' times, or the end
    /// of a preload's ramp.
    pub fn knots(&self) -> Vec<f64> {
        let ramp_end = |ramp: f64| if ramp > 0.0 { vec![ramp] } else { Vec::new() };
        match self {
            Force::Spring(s) => ramp_end(s.ramp),
            Force::Torsional(s) => ramp_end(s.ramp),
            Force::External(l) => [&l.force, &l.torque]
                .into_iter()
                .flatten()
                .flat_map(|p| p.knots())
                .collect(),
        }
    }
}

fn twist_of(r: BodyRef, v: &[f64]) -> Twist {
    r.map_or(Twist::zeros(), |i| vector6_at(v, 6 * i))
}

/// Adds the generalized wrench of an inertial force `f` applied at inertial point `x`.
fn add_point_force(out: &mut [f64], r: BodyRef, pose: &Pose, x: &Vector3<f64>, f: &Vector3<f64>) {
    if let Some(i) = r {
        let torque_body = pose.p.inverse_transform_vector(&(x - pose.x).cross(f));
        for k in 0..3 {
            out[6 * i + k] += f[k];
            out[6 * i + 3 + k] += torque_body[k];
        }
    }
}

fn add_torque(out: &mut [f64], r: BodyRef, pose: &Pose, torque_world: &Vector3<f64>) {
    if let Some(i) = r {
        let tb = pose.p.inverse_transform_vector(torque_world);
        for k in 0..3 {
            out[6 * i + 3 + k] += tb[k];
        }
    }
}

impl PointSpring {
    fn length(&self, poses: &[Pose]) -> (Vector3<f64>, Vector3<f64>, f64) {
        let xa = pose_of(self.a, poses).point(&self.point_a);
        let xb = pose_of(self.b, poses).point(&self.point_b);
        (xa, xb, (xb - xa).norm())
    }
}

impl TorsionalSpring {
    /// Builds the spring with φ = 0 in the configuration `poses`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        a: BodyRef,
        b: BodyRef,
        axis_a: Vector3<f64>,
        poses: &[Pose],
        stiffness: f64,
        damping: f64,
        preload: f64,
        rest_angle: f64,
    ) -> Self {
        let axis_a = axis_a.normalize();
        let pa = pose_of(a, poses);
        let pb = pose_of(b, poses);
        let r = any_orthogonal(&pa.dir(&axis_a));
        TorsionalSpring {
            a,
            b,
            axis_a,
            ref_a: pa.p.inverse_transform_vector(&r),
            ref_b: pb.p.inverse_transform_vector(&r),
            stiffness,
            damping,
            preload,
            rest_angle,
            ramp: 0.0,
        }
    }

    /// The axis in the world.
    pub fn axis(&self, poses: &[Pose]) -> Vector3<f64> {
        pose_of(self.a, poses).dir(&self.axis_a)
    }

    /// Relative angle φ ∈ (−π, π] of b about the axis, and the world axis.
    pub fn angle(&self, poses: &[Pose]) -> (f64, Vector3<f64>) {
        let pa = pose_of(self.a, poses);
        let pb = pose_of(self.b, poses);
        let n = self.axis(poses);
        let ra = pa.dir(&self.ref_a);
        let rb = pb.dir(&self.ref_b);
        let rb = rb - n * n.dot(&rb);
        (n.dot(&ra.cross(&rb)).atan2(ra.dot(&rb)), n)
    }
}

/// The angle of body b's frame from body a's about `axis_a` (a unit vector of a's frame,
/// the same vector of b's frame when the frames are aligned), in (−π, π]: zero where the
/// frames are aligned, whatever the configuration the scene was written in.
pub fn frame_angle(a: BodyRef, b: BodyRef, axis_a: &Vector3<f64>, poses: &[Pose]) -> f64 {
    let (pa, pb) = (pose_of(a, poses), pose_of(b, poses));
    let r = any_orthogonal(axis_a);
    let n = pa.dir(axis_a);
    let ra = pa.dir(&r);
    let rb = pb.dir(&r);
    let rb = rb - n * n.dot(&rb);
    n.dot(&ra.cross(&rb)).atan2(ra.dot(&rb))
}

impl Force {
    /// Bodies the element acts on.
    pub fn bodies(&self) -> [BodyRef; 2] {
        match self {
            Force::Spring(s) => [s.a, s.b],
            Force::Torsional(s) => [s.a, s.b],
            Force::External(l) => [Some(l.body), None],
        }
    }

    pub fn depends_on_velocity(&self) -> bool {
        match self {
            Force::Spring(s) => s.damping != 0.0,
            Force::Torsional(s) => s.damping != 0.0,
            Force::External(_) => false,
        }
    }

    /// `true` when only the bodies' orientations and angular velocities enter the wrench,
    /// so its Jacobian has no columns for the linear degrees of freedom.
    pub fn rotational_only(&self) -> bool {
        matches!(self, Force::Torsional(_))
    }

    /// `true` when the wrench changes with the pose (so it has a stiffness).
    pub fn depends_on_pose(&self) -> bool {
        match self {
            Force::External(l) => {
                l.frame == Frame::World && l.force.is_some() && l.point != Vector3::zeros()
                    || l.frame == Frame::World && l.torque.is_some()
            }
            _ => true,
        }
    }

    /// The damping's velocity Jacobian in closed form, where the element has one: each
    /// (body x, body y, ∂τ_x/∂ω_y), the body-frame torque on x against the body-frame angular
    /// velocity of y. A torsional damper's moment c n·(ω_b − ω_a) is linear in the twists
    /// and its axis does not depend on them, so the blocks are exact: with n_a, n_b the axis
    /// in each body's frame, aa = −c n_a n_aᵀ, ab = c n_a n_bᵀ, ba = c n_b n_aᵀ,
    /// bb = −c n_b n_bᵀ.
    /// The blocks replace `out`'s entries; false (and `out` untouched) where the element
    /// has no closed form.
    pub fn damping_jacobian(&self, poses: &[Pose], out: &mut Vec<RotationBlock>) -> bool {
        let Force::Torsional(s) = self else {
            return false;
        };
        let n = s.axis(poses);
        let local = |r: BodyRef| r.map(|i| (i, poses[i].p.inverse_transform_vector(&n)));
        let ends = [(local(s.a), -1.0), (local(s.b), 1.0)];
        let blocks = out;
        blocks.clear();
        // τ_a = +n m and τ_b = −n m with m ∋ c n·(ω_b − ω_a): sign(x) sign(y) = −(±)(±)
        for &(x, sx) in &ends {
            for &(y, sy) in &ends {
                if let (Some((i, nx)), Some((j, ny))) = (x, y) {
                    blocks.push((i, j, nx * ny.transpose() * (-s.damping * sx * sy)));
                }
            }
        }
        true
    }

    /// The stiffness in closed form, where the element has one: each (body x, body y,
    /// ∂τ_x/∂δ_y), the body-frame torque on x against a body-frame rotation increment δ_y
    /// of y (`Pose::advanced`), damping's pose dependence included. For a torsional spring,
    /// with n the world axis, r_a, r_b the reference directions, x = r_a·r_b,
    /// y = n·(r_a × r_b), φ = atan2(y, x), Ω the world angular velocities and w = R δ:
    /// - ∂φ/∂w_a = (x (n × (r_a × r_b) − x n) − y r_a × r_b) / (x² + y²),
    ///   ∂φ/∂w_b = (x (x n − (n·r_b) r_a) − y r_b × r_a) / (x² + y²);
    /// - ∂φ̇/∂w_a = n × Ω_b, ∂φ̇/∂w_b = Ω_b × n;
    /// - τ_a = n_a M (n_a the axis in a's frame, fixed), τ_b = −n_b M with n_b = R_bᵀ n,
    ///   ∂n_b/∂δ_b = [n_b]×, ∂n_b/∂δ_a = −R_bᵀ [n]× R_a.
    ///
    /// It replaces 6 to 12 evaluations of the wrench by finite differences per assembly.
    /// The blocks replace `out`'s entries; false (and `out` untouched) where the element
    /// has no closed form.
    pub fn stiffness_jacobian(
        &self,
        t: f64,
        poses: &[Pose],
        twists: &[f64],
        out: &mut Vec<RotationBlock>,
    ) -> bool {
        let Force::Torsional(s) = self else {
            return false;
        };
        let (pa, pb) = (pose_of(s.a, poses), pose_of(s.b, poses));
        let (rot_a, rot_b) = (
            *pa.p.to_rotation_matrix().matrix(),
            *pb.p.to_rotation_matrix().matrix(),
        );
        let n = rot_a * s.axis_a;
        let (ra, rb) = (rot_a * s.ref_a, rot_b * s.ref_b);
        let (x, y) = (ra.dot(&rb), n.dot(&ra.cross(&rb)));
        let (phi, _) = s.angle(poses);
        let omega = |r: BodyRef, rot: &Matrix3<f64>| rot * twist_of(r, twists).fixed_rows::<3>(3);
        let (om_a, om_b) = (omega(s.a, &rot_a), omega(s.b, &rot_b));
        let q = x * x + y * y;
        let cross = ra.cross(&rb);
        let dphi_a = (n.cross(&cross) * x - n * (x * x) - cross * y) / q;
        let dphi_b = (n * (x * x) - ra * (x * n.dot(&rb)) + cross * y) / q;
        let (drate_a, drate_b) = (n.cross(&om_b), om_b.cross(&n));
        let moment = ramped(s.preload, s.ramp, t)
            + s.stiffness * (phi - s.rest_angle)
            + s.damping * n.dot(&(om_b - om_a));
        // ∂M/∂δ as body-frame rows
        let dm_a = rot_a.transpose() * (dphi_a * s.stiffness + drate_a * s.damping);
        let dm_b = rot_b.transpose() * (dphi_b * s.stiffness + drate_b * s.damping);
        let n_b = rot_b.transpose() * n;
        let blocks = out;
        blocks.clear();
        if let Some(i) = s.a {
            blocks.push((i, i, s.axis_a * dm_a.transpose()));
            if let Some(j) = s.b {
                blocks.push((i, j, s.axis_a * dm_b.transpose()));
            }
        }
        if let Some(j) = s.b {
            if let Some(i) = s.a {
                blocks.push((
                    j,
                    i,
                    -n_b * dm_a.transpose() + rot_b.transpose() * skew(&n) * rot_a * moment,
                ));
            }
            blocks.push((j, j, -n_b * dm_b.transpose() - skew(&n_b) * moment));
        }
        true
    }

    /// Adds the element's generalized wrench at time `t` to `out`, given the generalized
    /// velocity `twists` (both 6 entries per body: inertial force, body-frame torque).
    pub fn apply(&self, t: f64, poses: &[Pose], twists: &[f64], out: &mut [f64]) {
        match self {
            Force::Spring(s) => {
                let (xa, xb, l) = s.length(poses);
                if l <= f64::MIN_POSITIVE {
                    return;
                }
                let u = (xb - xa) / l;
                let pa = pose_of(s.a, poses);
                let pb = pose_of(s.b, poses);
                let ldot = if s.damping != 0.0 {
                    u.dot(
                        &(point_velocity(pb, &twist_of(s.b, twists), &xb)
                            - point_velocity(pa, &twist_of(s.a, twists), &xa)),
                    )
                } else {
                    0.0
                };
                let tension = ramped(s.preload, s.ramp, t)
                    + s.stiffness * (l - s.rest_length)
                    + s.damping * ldot;
                add_point_force(out, s.a, pa, &xa, &(u * tension));
                add_point_force(out, s.b, pb, &xb, &(-u * tension));
            }
            Force::Torsional(s) => {
                let (phi, n) = s.angle(poses);
                let pa = pose_of(s.a, poses);
                let pb = pose_of(s.b, poses);
                let phidot = if s.damping != 0.0 {
                    let wa = pa.p * twist_of(s.a, twists).fixed_rows::<3>(3);
                    let wb = pb.p * twist_of(s.b, twists).fixed_rows::<3>(3);
                    n.dot(&(wb - wa))
                } else {
                    0.0
                };
                let m = ramped(s.preload, s.ramp, t)
                    + s.stiffness * (phi - s.rest_angle)
                    + s.damping * phidot;
                add_torque(out, s.a, pa, &(n * m));
                add_torque(out, s.b, pb, &(-n * m));
            }
            Force::External(l) => {
                let pose = poses[l.body];
                let to_world = |v: Vector3<f64>| match l.frame {
                    Frame::World => v,
                    Frame::Body => pose.dir(&v),
                };
                if let Some(f) = &l.force {
                    let f = to_world(f.at(t));
                    add_point_force(out, Some(l.body), &pose, &pose.point(&l.point), &f);
                }
                if let Some(m) = &l.torque {
                    add_torque(out, Some(l.body), &pose, &to_world(m.at(t)));
                }
            }
        }
    }

    /// Potential energy of the conservative part (springs, constant world-frame forces);
    /// zero for time-varying or follower loads, which have none.
    pub fn potential(&self, poses: &[Pose]) -> f64 {
        match self {
            Force::Spring(s) => {
                let d = s.length(poses).2 - s.rest_length;
                s.preload * d + 0.5 * s.stiffness * d * d
            }
            Force::Torsional(s) => {
                let d = s.angle(poses).0 - s.rest_angle;
                s.preload * d + 0.5 * s.stiffness * d * d
            }
            Force::External(l) => match (&l.force, l.frame) {
                (Some(LoadProfile::Constant(f)), Frame::World) => {
                    -f.dot(&poses[l.body].point(&l.point))
                }
                _ => 0.0,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::{UnitQuaternion, Vector6};

    #[test]
    fn table_profile_interpolates_and_clamps() {
        let p = LoadProfile::Table(vec![
            (0.0, Vector3::new(0.0, 0.0, 0.0)),
            (1.0, Vector3::new(2.0, 0.0, 0.0)),
            (3.0, Vector3::new(2.0, 4.0, 0.0)),
        ]);
        assert_relative_eq!(p.at(-1.0).x, 0.0);
        assert_relative_eq!(p.at(0.25).x, 0.5);
        assert_relative_eq!(p.at(2.0).y, 2.0);
        assert_relative_eq!(p.at(9.0), Vector3::new(2.0, 4.0, 0.0));
    }

    fn check_gradient(f: &Force, poses: &[Pose], dofs: &[usize]) {
        let mut w = [0.0; 12];
        f.apply(0.0, poses, &[0.0; 12], &mut w);
        for b in 0..2 {
            for &k in dofs {
                let eps = 1e-6;
                let mut d = Vector6::zeros();
                d[k] = eps;
                let (mut plus, mut minus) = (poses.to_vec(), poses.to_vec());
                plus[b] = poses[b].advanced(&d);
                minus[b] = poses[b].advanced(&(-d));
                let grad = (f.potential(&plus) - f.potential(&minus)) / (2.0 * eps);
                assert!(
                    (w[6 * b + k] + grad).abs() < 1e-6 * (1.0 + grad.abs()),
                    "{f:?} body {b} dof {k}: wrench {} vs -dV {}",
                    w[6 * b + k],
                    -grad
                );
            }
        }
    }

    /// Two bodies in general position: translated and tilted about all three axes.
    fn tilted_poses() -> Vec<Pose> {
        vec![
            Pose {
                x: Vector3::new(0.1, 0.2, 0.3),
                p: UnitQuaternion::from_euler_angles(0.3, -0.2, 0.5),
            },
            Pose {
                x: Vector3::new(1.0, -0.4, 0.7),
                p: UnitQuaternion::from_euler_angles(-0.1, 0.4, 1.2),
            },
        ]
    }

    /// Body-frame twists of two bodies spinning about every axis.
    const SPINNING: [f64; 12] = [
        0.1, -0.2, 0.3, 4.0, -2.5, 7.0, -0.4, 0.5, 0.2, -3.0, 1.5, 9.0,
    ];

    /// A torsional spring and damper on a tilted axis from `a` to body 1 (k = 5, c = 0.7,
    /// preload 1.5), at φ = 0 in `built`.
    fn tilted_spring(a: BodyRef, built: &[Pose], rest_angle: f64) -> TorsionalSpring {
        TorsionalSpring::new(
            a,
            Some(1),
            Vector3::new(0.2, -0.3, 1.0),
            built,
            5.0,
            0.7,
            1.5,
            rest_angle,
        )
    }

    /// A constant world force on body 0: an element without closed-form Jacobians.
    fn constant_load() -> Force {
        Force::External(ExternalLoad {
            body: 0,
            point: Vector3::zeros(),
            force: Some(LoadProfile::Constant(Vector3::new(0.0, 0.0, -1.0))),
            torque: None,
            frame: Frame::World,
        })
    }

    /// The wrench of each element is minus the gradient of its potential (central finite
    /// differences along translations and body-frame rotations): a wrong sign or lever arm
    /// fails this.
    #[test]
    fn forces_derive_from_their_potentials() {
        let poses = tilted_poses();
        let spring = Force::Spring(PointSpring {
            ramp: 0.0,
            a: Some(0),
            point_a: Vector3::new(0.05, 0.0, 0.02),
            b: Some(1),
            point_b: Vector3::new(0.0, 0.1, 0.0),
            stiffness: 300.0,
            damping: 0.0,
            rest_length: 0.5,
            preload: 7.0,
        });
        let load = Force::External(ExternalLoad {
            body: 1,
            point: Vector3::new(0.0, 0.0, 1.0),
            force: Some(LoadProfile::Constant(Vector3::new(0.0, 0.0, -20.0))),
            torque: None,
            frame: Frame::World,
        });
        check_gradient(&spring, &poses, &[0, 1, 2, 3, 4, 5]);
        check_gradient(&load, &poses, &[0, 1, 2, 3, 4, 5]);

        // A torsional spring acts about its axis: both bodies share body-z as the axis.
        let rz = |a: f64| UnitQuaternion::from_euler_angles(0.0, 0.0, a);
        let start = vec![
            Pose {
                x: Vector3::zeros(),
                p: rz(0.3),
            },
            Pose {
                x: Vector3::new(0.2, 0.0, 0.0),
                p: rz(0.3),
            },
        ];
        let tors = Force::Torsional(TorsionalSpring::new(
            Some(0),
            Some(1),
            Vector3::new(0.0, 0.0, 1.0),
            &start,
            2.0,
            0.0,
            0.4,
            0.1,
        ));
        let turned = vec![
            start[0],
            Pose {
                x: start[1].x,
                p: rz(1.1),
            },
        ];
        if let Force::Torsional(s) = &tors {
            assert_relative_eq!(s.angle(&turned).0, 0.8, epsilon = 1e-14);
        }
        check_gradient(&tors, &turned, &[0, 1, 2, 5]);
    }

    /// The torsional spring's closed-form stiffness (with its damping's pose dependence and
    /// a ramping preload) matches central differences of its wrench in every body-frame
    /// rotation increment, in a tilted 3D pose with the bodies spinning, for a spring
    /// between two bodies and one to the ground (a wrong sign, a missing term or a
    /// transposed block fails it).
    #[test]
    fn torsional_stiffness_matches_differences() {
        let poses = tilted_poses();
        let twists = SPINNING;
        // built at other poses, so that φ ≠ 0 and the reference directions leave the plane
        let built = vec![
            poses[0],
            Pose {
                x: poses[1].x,
                p: poses[1].p * UnitQuaternion::from_euler_angles(0.05, -0.08, -0.9),
            },
        ];
        for a in [Some(0), None] {
            let mut spring = tilted_spring(a, &built, 0.2);
            spring.ramp = 2.0;
            let f = Force::Torsional(spring);
            let t = 0.5;
            let mut blocks = Vec::new();
            assert!(
                f.stiffness_jacobian(t, &poses, &twists, &mut blocks),
                "a spring has one"
            );
            assert_eq!(blocks.len(), if a.is_some() { 4 } else { 1 });
            let mut largest: f64 = 0.0;
            for (x, y, d) in blocks {
                for k in 0..3 {
                    let eps = 1e-6;
                    let mut step = Vector6::zeros();
                    step[3 + k] = eps;
                    let (mut plus, mut minus) = (poses.clone(), poses.clone());
                    plus[y] = poses[y].advanced(&step);
                    minus[y] = poses[y].advanced(&(-step));
                    let (mut wp, mut wm) = ([0.0; 12], [0.0; 12]);
                    f.apply(t, &plus, &twists, &mut wp);
                    f.apply(t, &minus, &twists, &mut wm);
                    for r in 0..3 {
                        let fd = (wp[6 * x + 3 + r] - wm[6 * x + 3 + r]) / (2.0 * eps);
                        largest = largest.max(fd.abs());
                        assert_relative_eq!(d[(r, k)], fd, epsilon = 1e-7, max_relative = 1e-6);
                    }
                }
            }
            assert!(
                largest > 1.0,
                "the blocks are not trivially zero: {largest}"
            );
        }
        assert!(!constant_load().stiffness_jacobian(0.0, &poses, &twists, &mut Vec::new()));
    }

    /// The torsional damper's closed-form velocity Jacobian matches central differences of
    /// its wrench in every body-frame angular velocity component, in a tilted 3D pose with
    /// the bodies spinning (a wrong sign or a transposed block fails it).
    #[test]
    fn torsional_damping_jacobian_matches_differences() {
        let poses = tilted_poses();
        let f = Force::Torsional(tilted_spring(Some(0), &poses, 0.0));
        let twists = SPINNING;
        let mut blocks = Vec::new();
        assert!(f.damping_jacobian(&poses, &mut blocks), "a damper has one");
        assert_eq!(blocks.len(), 4);
        for (x, y, d) in blocks {
            for k in 0..3 {
                let eps = 1e-4;
                let (mut plus, mut minus) = (twists, twists);
                plus[6 * y + 3 + k] += eps;
                minus[6 * y + 3 + k] -= eps;
                let (mut wp, mut wm) = ([0.0; 12], [0.0; 12]);
                f.apply(0.0, &poses, &plus, &mut wp);
                f.apply(0.0, &poses, &minus, &mut wm);
                for r in 0..3 {
                    let fd = (wp[6 * x + 3 + r] - wm[6 * x + 3 + r]) / (2.0 * eps);
                    assert_relative_eq!(d[(r, k)], fd, epsilon = 1e-9, max_relative = 1e-7);
                }
            }
        }
        // other elements have none
        assert!(!constant_load().damping_jacobian(&poses, &mut Vec::new()));
    }
}
