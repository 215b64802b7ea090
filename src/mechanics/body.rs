//! A rigid body in Newton–Euler form: q = (x_G, p) with p a unit quaternion, twist
//! v = (v_G, Ω) with v_G inertial and Ω in the body frame, constant mass matrix
//! diag(m I₃, I_body).

use crate::math::compose_body;
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3, Vector4, Vector6};

/// A body index, or `None` for the ground (the fixed inertial frame).
pub type BodyRef = Option<usize>;

/// The pose of body `r` among `poses`; the ground's (the identity) for `None`.
///
/// A reference, not a copy: a copy of a pose that a step has just written is read back
/// in 16-byte pieces that straddle the ones it was stored in, and each waits for the
/// stores to complete (measured: a third of the time of a joint's rows).
pub fn pose_of(r: BodyRef, poses: &[Pose]) -> &Pose {
    r.map_or(&GROUND, |i| &poses[i])
}

/// Whether body `b` integrates any of its six degrees of freedom in the per-dof `mask`
/// (`Model::dof_mask`).
#[inline]
pub fn moves(mask: &[bool], b: usize) -> bool {
    mask[6 * b..6 * b + 6].iter().any(|&m| m)
}

/// Whether body `b` integrates all six of its degrees of freedom in the per-dof `mask`,
/// holding none: most bodies, whose blocks need no masking.
#[inline]
pub fn holds_none(mask: &[bool], b: usize) -> bool {
    mask[6 * b..6 * b + 6].iter().all(|&m| m)
}

/// The ground's pose: the inertial frame.
static GROUND: Pose = Pose {
    x: Vector3::new(0.0, 0.0, 0.0),
    p: UnitQuaternion::new_unchecked(Quaternion::from_vector(Vector4::new(0.0, 0.0, 0.0, 1.0))),
};

/// Twist of a body as (v inertial, Ω body).
pub type Twist = Vector6<f64>;

/// Velocity of the material point currently at `x` (inertial) of a body at `pose` moving
/// with twist `tw`: v + R Ω × (x − x_G).
pub fn point_velocity(pose: &Pose, tw: &Twist, x: &Vector3<f64>) -> Vector3<f64> {
    let omega = pose.p * tw.fixed_rows::<3>(3);
    tw.fixed_rows::<3>(0) + omega.cross(&(x - pose.x))
}

/// Position and orientation of a body frame in the inertial frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    pub x: Vector3<f64>,
    pub p: UnitQuaternion<f64>,
}

impl Pose {
    pub fn identity() -> Self {
        Pose {
            x: Vector3::zeros(),
            p: UnitQuaternion::identity(),
        }
    }

    /// Inertial coordinates of the material point `local` (body coordinates).
    #[inline]
    pub fn point(&self, local: &Vector3<f64>) -> Vector3<f64> {
        self.x + self.p * local
    }

    /// Body coordinates of the inertial point `x`: the inverse of `point`.
    #[inline]
    pub fn local(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.p.inverse_transform_vector(&(x - self.x))
    }

    /// Inertial direction of the body-frame vector `local`.
    #[inline]
    pub fn dir(&self, local: &Vector3<f64>) -> Vector3<f64> {
        self.p * local
    }

    /// Lie-group update on R³ × SU(2): x ← x + Δ[0..3], p ← p ⊗ expq(Δ[3..6]) with the
    /// rotation increment in the body frame.
    #[inline]
    pub fn advanced(&self, delta: &Vector6<f64>) -> Pose {
        Pose {
            x: self.x + delta.fixed_rows::<3>(0),
            p: compose_body(&self.p, &delta.fixed_rows::<3>(3).into_owned()),
        }
    }
}

/// Which degrees of freedom a body has.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Motion {
    /// Six degrees of freedom.
    #[default]
    Free,
    /// Rotates about its reference point, which stays fixed (inertia is about that point):
    /// a spherical pivot without modelling a joint, as in the heavy-top benchmark.
    Pinned,
    /// Does not move (frame, ground, fixed parts).
    Fixed,
}

/// A body held to a plane of the world: its translation along the plane's normal (world
/// axis `normal`) and its rotations about the two body axes other than `spin` (the body
/// axis along that normal) are held. For planar mechanisms whose out-of-plane motion is
/// not part of the question: a journal with a large clearance in a short bore can tilt a
/// long way, and a swing that starts in its plane can leave it (docs/clearance-joint.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Planar {
    pub normal: usize,
    pub spin: usize,
}

/// Shapes whose inertia can be derived from the mass (uniform density, about the centre).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// Full side lengths along the body axes.
    Box {
        size: Vector3<f64>,
    },
    /// Axis along body z.
    Cylinder {
        radius: f64,
        length: f64,
    },
    Sphere {
        radius: f64,
    },
}

impl Shape {
    /// Body-frame inertia tensor of a uniform solid of mass `m`.
    pub fn inertia(&self, m: f64) -> Matrix3<f64> {
        match *self {
            Shape::Box { size } => {
                let (a2, b2, c2) = (size.x * size.x, size.y * size.y, size.z * size.z);
                Matrix3::from_diagonal(&Vector3::new(b2 + c2, a2 + c2, a2 + b2)) * (m / 12.0)
            }
            Shape::Cylinder { radius, length } => {
                let r2 = radius * radius;
                let t = m * (3.0 * r2 + length * length) / 12.0;
                Matrix3::from_diagonal(&Vector3::new(t, t, 0.5 * m * r2))
            }
            Shape::Sphere { radius } => Matrix3::identity() * (0.4 * m * radius * radius),
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct RigidBody {
    pub name: String,
    pub mass: f64,
    /// Body-frame inertia about the reference point (the centre of mass unless pinned).
    pub inertia: Matrix3<f64>,
    pub pose: Pose,
    /// Velocity of the reference point, inertial frame.
    pub velocity: Vector3<f64>,
    /// Angular velocity Ω, body frame.
    pub angular_velocity: Vector3<f64>,
    pub motion: Motion,
    /// Held to a plane, on top of `motion`.
    pub planar: Option<Planar>,
}

impl RigidBody {
    pub fn new(name: impl Into<String>, mass: f64, inertia: Matrix3<f64>) -> Self {
        RigidBody {
            name: name.into(),
            mass,
            inertia,
            pose: Pose::identity(),
            velocity: Vector3::zeros(),
            angular_velocity: Vector3::zeros(),
            motion: Motion::Free,
            planar: None,
        }
    }

    pub fn fixed(name: impl Into<String>) -> Self {
        let mut b = RigidBody::new(name, 0.0, Matrix3::zeros());
        b.motion = Motion::Fixed;
        b
    }

    pub fn at(mut self, x: Vector3<f64>) -> Self {
        self.pose.x = x;
        self
    }

    pub fn oriented(mut self, p: UnitQuaternion<f64>) -> Self {
        self.pose.p = p;
        self
    }

    pub fn with_velocity(mut self, v: Vector3<f64>, omega_body: Vector3<f64>) -> Self {
        self.velocity = v;
        self.angular_velocity = omega_body;
        self
    }

    pub fn with_motion(mut self, motion: Motion) -> Self {
        self.motion = motion;
        self
    }

    /// `true` for the degrees of freedom that are integrated (3 translations, 3 rotations).
    pub fn dof_mask(&self) -> [bool; 6] {
        let mut mask = match self.motion {
            Motion::Free => [true; 6],
            Motion::Pinned => [false, false, false, true, true, true],
            Motion::Fixed => [false; 6],
        };
        if let Some(p) = self.planar {
            mask[p.normal] = false;
            (0..3)
                .filter(|&k| k != p.spin)
                .for_each(|k| mask[3 + k] = false);
        }
        mask
    }

    /// √(tr I / 2m): the root-mean-square distance of the body's mass from its reference
    /// point (for a solid sphere of radius r, √(3/5) r), the length by which a rotation of
    /// the body moves a typical point of it.
    pub fn radius_of_gyration(&self) -> f64 {
        if self.mass > 0.0 {
            (self.inertia.trace() / (2.0 * self.mass)).sqrt()
        } else {
            0.0
        }
    }

    /// Kinetic energy ½ m |v|² + ½ Ωᵀ I Ω for the given twist.
    pub fn kinetic_energy(&self, v: &Vector3<f64>, omega: &Vector3<f64>) -> f64 {
        let trans = if self.motion == Motion::Free {
            0.5 * self.mass * v.norm_squared()
        } else {
            0.0
        };
        trans + 0.5 * omega.dot(&(self.inertia * omega))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn shape_inertias_match_textbook_values() {
        let b = Shape::Box {
            size: Vector3::new(1.0, 2.0, 3.0),
        }
        .inertia(12.0);
        assert_relative_eq!(b.diagonal(), Vector3::new(13.0, 10.0, 5.0), epsilon = 1e-14);
        let c = Shape::Cylinder {
            radius: 1.0,
            length: 2.0,
        }
        .inertia(12.0);
        assert_relative_eq!(c.diagonal(), Vector3::new(7.0, 7.0, 6.0), epsilon = 1e-14);
        let s = Shape::Sphere { radius: 0.1 }.inertia(1.0);
        assert_relative_eq!(s[(0, 0)], 0.004, epsilon = 1e-16);
    }

    #[test]
    fn pose_update_moves_points_rigidly() {
        let pose = Pose::identity();
        let d = Vector6::new(1.0, 0.0, 0.0, 0.0, 0.0, std::f64::consts::FRAC_PI_2);
        let q = pose.advanced(&d);
        assert_relative_eq!(
            q.point(&Vector3::new(1.0, 0.0, 0.0)),
            Vector3::new(1.0, 1.0, 0.0),
            epsilon = 1e-15
        );
    }
}
