//! Unilateral frictional contacts: a pair of primitives on two bodies expands into a fixed
//! list of candidate points. Each candidate gives its gap, local frame (n, t1, t2) and the
//! 3×6 Jacobian blocks G₁, G₂ mapping the body twists to the local relative velocity
//! (the lever arm of both bodies is taken at the point on body 1). The blocks are built
//! when asked for: a mechanism evaluates all its candidates at every step, and most of
//! them are never in a velocity problem.

pub mod clearance;
pub mod compliant;
pub mod convex;
pub mod mesh;
pub mod primitives;
pub mod profile;
pub mod revolution;

pub use primitives::{ContactGeometry, Primitive};

use super::body::BodyRef;
use super::body::{pose_of, Pose};
use crate::math::blocks::{vector3_at, vector6_at};
use crate::math::{skew, tangent_basis};
use nalgebra::{Matrix3, Matrix3x6, RowVector6, Vector3};

/// Contact between a primitive on body 1 and one on body 2 (`None` = the ground frame).
/// The normal points from body 2 towards body 1; the gap is positive when separated.
#[derive(Clone, Debug, PartialEq)]
pub struct ContactPair {
    pub name: String,
    pub body1: BodyRef,
    pub shape1: Primitive,
    pub body2: BodyRef,
    pub shape2: Primitive,
    /// Coulomb friction coefficient μ ≥ 0.
    pub mu: f64,
    /// Newton restitution coefficient e ∈ [0, 1].
    pub e: f64,
}

/// One evaluated candidate contact point.
#[derive(Clone, Copy, Debug)]
pub struct ContactPoint {
    pub geometry: ContactGeometry,
    /// Rows n, t1, t2.
    pub frame: Matrix3<f64>,
    pub body1: BodyRef,
    pub body2: BodyRef,
    jacobian: Jacobian,
    pub mu: f64,
    pub e: f64,
    /// Whether the law is on the linearised end-of-step gap, g + h u_N,θ ≥ 0, instead of on
    /// u_N ≥ 0. Clearance guards use it: they enter the velocity problem while still open
    /// (the step would carry the journal through them), so they must stop the journal where
    /// the gap closes, not where it is now.
    pub gap_law: bool,
    /// How the gap bends across its normal, where that matters to the projection (a bore
    /// ring against its journal); `None` for a gap that is flat on the scale of a correction.
    pub lateral: Option<Lateral>,
}

/// What a contact point's Jacobian blocks are made from.
#[derive(Clone, Copy, Debug)]
enum Jacobian {
    /// G_b = ±[F, F skew(x_b − p) R_b] for the frame's rows F, from each body's rotation
    /// R_b and the arm x_b − p from the contact point to its centre.
    Lever {
        rotation: [Matrix3<f64>; 2],
        arm: [Vector3<f64>; 2],
    },
    /// Normal rows given outright, no tangential rows (a joint stop's).
    Normal {
        g1: RowVector6<f64>,
        g2: RowVector6<f64>,
    },
}

/// The second-order part of a gap that curves sharply across its normal. A bore ring
/// against its journal has g = c − |e|, e the offset of the journal axis in the ring plane:
/// moving the axis by s across the normal lowers the gap by s²/(2|e|). At a clearance of a
/// micrometre that term dwarfs the linear one for corrections that the mass metric finds
/// cheap (a long bar swung about its centre of mass moves its journal sideways), so the
/// projection needs it (`integrator/projection.rs`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lateral {
    /// Gradient blocks of the lateral displacement s for bodies 1 and 2 (twist coordinates).
    pub g1: RowVector6<f64>,
    pub g2: RowVector6<f64>,
    /// κ in g(q ⊕ Δν) ≈ g + G_N Δν − ½ κ s² (1/m).
    pub kappa: f64,
}

/// Gradient (twist coordinates) of the displacement along `dir` of the material point of a
/// body at `point`: dirᵀ (v + ω × (point − x)).
pub fn point_row(dir: &Vector3<f64>, body: &BodyFrame, point: &Vector3<f64>) -> RowVector6<f64> {
    lever_row(dir, &lever(body, point))
}

/// A body's pose with its rotation matrix, built once where several contact points share
/// the body (a clearance joint's 22).
#[derive(Clone, Copy, Debug)]
pub struct BodyFrame {
    pub pose: Pose,
    pub rotation: Matrix3<f64>,
}

impl BodyFrame {
    pub fn new(pose: &Pose) -> Self {
        BodyFrame {
            pose: *pose,
            rotation: *pose.p.to_rotation_matrix().matrix(),
        }
    }
}

/// skew(x − point) R: maps the body-frame angular velocity to the velocity of the material
/// point at `point` due to the rotation. Built once per body and contact, it serves the
/// three rows of the contact frame.
fn lever(body: &BodyFrame, point: &Vector3<f64>) -> Matrix3<f64> {
    lever_of(&(body.pose.x - point), &body.rotation)
}

/// skew(arm) R for the arm x − point of a body with rotation R.
fn lever_of(arm: &Vector3<f64>, rotation: &Matrix3<f64>) -> Matrix3<f64> {
    skew(arm) * rotation
}

/// [dirᵀ, dirᵀ lever]: the gradient row of `point_row` for a lever built by `lever`.
fn lever_row(dir: &Vector3<f64>, lever: &Matrix3<f64>) -> RowVector6<f64> {
    let mut row = RowVector6::zeros();
    row.fixed_columns_mut::<3>(0).copy_from(&dir.transpose());
    row.fixed_columns_mut::<3>(3)
        .copy_from(&(dir.transpose() * lever));
    row
}

impl ContactPair {
    /// Whether the contact normal is the same at any poses: that of a plane which cannot
    /// turn, on the ground or on a body whose rotations are held (`mask`, the model's
    /// integrated degrees of freedom). A plane always goes second in a pair.
    pub fn normal_is_fixed(&self, mask: &[bool]) -> bool {
        matches!(self.shape2, Primitive::Plane { .. })
            && self
                .body2
                .is_none_or(|b| mask[6 * b + 3..6 * b + 6].iter().all(|&m| !m))
    }

    /// Builds a pair, ordering the shapes so that body 2 carries the plane, the profile,
    /// the mesh, the box or convex part met by a sphere or point, or the second of two
    /// like shapes. Returns an error message for an unsupported combination.
    pub fn new(
        name: impl Into<String>,
        body1: BodyRef,
        shape1: Primitive,
        body2: BodyRef,
        shape2: Primitive,
        mu: f64,
        e: f64,
    ) -> Result<Self, String> {
        let goes_second = |s: &Primitive, other: &Primitive| match s {
            Primitive::Plane { .. } => !matches!(other, Primitive::Plane { .. }),
            Primitive::Box { .. } | Primitive::Convex(_) => matches!(
                other,
                Primitive::Sphere { .. }
                    | Primitive::Point { .. }
                    | Primitive::Capsule { .. }
                    | Primitive::Cylinder { .. }
                    | Primitive::Cone { .. }
            ),
            Primitive::Profile(_) => !matches!(other, Primitive::Profile(_)),
            Primitive::Mesh(_) => !matches!(other, Primitive::Mesh(_) | Primitive::Plane { .. }),
            _ => false,
        };
        let (body1, shape1, body2, shape2) = if goes_second(&shape1, &shape2) {
            (body2, shape2, body1, shape1)
        } else {
            (body1, shape1, body2, shape2)
        };
        // a box meeting a convex part, a mesh, a capsule, a cylinder or a cone is taken as
        // the convex part it is
        let polyhedral = |s: &Primitive| matches!(s, Primitive::Convex(_) | Primitive::Mesh(_));
        let (shape1, shape2) = match (shape1, shape2) {
            (b @ Primitive::Box { .. }, other) if polyhedral(&other) => (b.into_convex(), other),
            (
                s1 @ (Primitive::Convex(_)
                | Primitive::Capsule { .. }
                | Primitive::Cylinder { .. }
                | Primitive::Cone { .. }),
                b @ Primitive::Box { .. },
            ) => (s1, b.into_convex()),
            pair => pair,
        };
        let supported = matches!(
            (&shape1, &shape2),
            (Primitive::Sphere { .. }, Primitive::Sphere { .. })
                | (
                    Primitive::Sphere { .. } | Primitive::Point { .. },
                    Primitive::Box { .. } | Primitive::Convex(_) | Primitive::Mesh(_)
                )
                | (
                    Primitive::Sphere { .. }
                        | Primitive::Point { .. }
                        | Primitive::Cylinder { .. }
                        | Primitive::Profile(_),
                    Primitive::Profile(_)
                )
                | (
                    Primitive::Convex(_),
                    Primitive::Convex(_) | Primitive::Mesh(_)
                )
                | (Primitive::Capsule { .. }, Primitive::Convex(_))
                | (
                    Primitive::Cylinder { .. } | Primitive::Cone { .. },
                    Primitive::Convex(_) | Primitive::Mesh(_)
                )
                | (
                    Primitive::Sphere { .. }
                        | Primitive::Box { .. }
                        | Primitive::Cylinder { .. }
                        | Primitive::Cone { .. }
                        | Primitive::Capsule { .. }
                        | Primitive::Point { .. }
                        | Primitive::Convex(_),
                    Primitive::Plane { .. }
                )
        );
        if !supported {
            return Err(format!(
                "unsupported contact pair {} – {} (supported: sphere, box, cylinder, cone, capsule, point or convex against a plane; sphere or point against a box, a convex part or a mesh; capsule against a box or a convex part; cylinder or cone against a box, a convex part or a mesh; sphere against sphere; point, sphere, cylinder or profile against a profile; convex or box against a convex part or a mesh)",
                shape1.kind(),
                shape2.kind()
            ));
        }
        if body1 == body2 {
            return Err("a contact needs two different bodies".into());
        }
        Ok(ContactPair {
            name: name.into(),
            body1,
            shape1,
            body2,
            shape2,
            mu,
            e,
        })
    }

    /// Number of candidate points this pair expands into.
    pub fn candidates(&self) -> usize {
        match (&self.shape1, &self.shape2) {
            (Primitive::Profile(a), Primitive::Profile(b)) => b.candidate_count_against(a),
            (pin, Primitive::Profile(p)) => p.candidate_count(pin.pin_faces()),
            (Primitive::Convex(a), Primitive::Convex(b)) => a.vertices.len() + b.vertices.len() + 1,
            (Primitive::Convex(a), Primitive::Mesh(_)) => a.vertices.len(),
            (Primitive::Capsule { .. }, Primitive::Convex(b)) => b.vertices.len() + 3,
            (
                round @ (Primitive::Cylinder { .. } | Primitive::Cone { .. }),
                Primitive::Convex(b),
            ) => {
                let rev = revolution::Revolution::of(round).expect("a cylinder or a cone");
                2 + b.vertices.len() + rev.side_edges(b) + 1
            }
            (Primitive::Cylinder { .. } | Primitive::Cone { .. }, Primitive::Mesh(_)) => 2,
            (_, Primitive::Convex(_) | Primitive::Mesh(_)) => 1,
            (s1, _) => s1.candidate_count(),
        }
    }

    /// Geometry and Jacobian of candidate `k` at the given body poses.
    pub fn evaluate(&self, k: usize, poses: &[Pose]) -> ContactPoint {
        let mut point = ContactPoint::placeholder();
        self.write(k, poses, &mut point);
        point
    }

    /// `evaluate` written over `slot`, where it is built: a point of 520 bytes built aside
    /// and copied into a list is read back while its stores are still in flight. (Inlined,
    /// it was built aside again.)
    #[inline(never)]
    pub fn write(&self, k: usize, poses: &[Pose], slot: &mut ContactPoint) {
        let (p1, p2) = (pose_of(self.body1, poses), pose_of(self.body2, poses));
        let (f1, f2) = (BodyFrame::new(p1), BodyFrame::new(p2));
        // a pin on a profile carries the lateral curvature of a concave arc
        let pin_on_profile = match (&self.shape1, &self.shape2) {
            (Primitive::Profile(_), _) => None,
            (pin, Primitive::Profile(profile)) => Some((pin, profile)),
            _ => None,
        };
        if let Some((pin, profile)) = pin_on_profile {
            let c = profile.contact(p2, &profile::Pin::of(pin, p1), k);
            slot.renew(
                c.geometry, self.body1, &f1, self.body2, &f2, None, self.mu, self.e,
            );
            slot.lateral = c.lateral.map(|(dir, at, kappa)| Lateral {
                g1: point_row(&dir, &f1, &at),
                g2: -point_row(&dir, &f2, &at),
                kappa,
            });
            return;
        }
        let geometry = primitives::closest(&self.shape1, p1, &self.shape2, p2, k);
        slot.renew(
            geometry, self.body1, &f1, self.body2, &f2, None, self.mu, self.e,
        );
    }
}

impl ContactPoint {
    /// Builds the local frame of a contact from its geometry and keeps what its Jacobian
    /// blocks are made from; the tangent basis is Frisvad's completion of n unless
    /// `tangents` gives one.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        geometry: ContactGeometry,
        body1: BodyRef,
        p1: &BodyFrame,
        body2: BodyRef,
        p2: &BodyFrame,
        tangents: Option<(Vector3<f64>, Vector3<f64>)>,
        mu: f64,
        e: f64,
    ) -> ContactPoint {
        let mut point = ContactPoint::placeholder();
        point.renew(geometry, body1, p1, body2, p2, tangents, mu, e);
        point
    }

    /// `new` written over this point, field by field where it lies: a point of 520 bytes
    /// built aside and copied in is read back in pieces that straddle those it was stored
    /// in, and the copy waits for every store to complete.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn renew(
        &mut self,
        geometry: ContactGeometry,
        body1: BodyRef,
        p1: &BodyFrame,
        body2: BodyRef,
        p2: &BodyFrame,
        tangents: Option<(Vector3<f64>, Vector3<f64>)>,
        mu: f64,
        e: f64,
    ) {
        let n = geometry.normal;
        let (t1, t2) = tangents.unwrap_or_else(|| tangent_basis(&n));
        self.frame = Matrix3::from_rows(&[n.transpose(), t1.transpose(), t2.transpose()]);
        let arm = |body: &BodyFrame| body.pose.x - geometry.point1;
        self.jacobian = Jacobian::Lever {
            rotation: [p1.rotation, p2.rotation],
            arm: [arm(p1), arm(p2)],
        };
        self.geometry = geometry;
        self.body1 = body1;
        self.body2 = body2;
        self.mu = mu;
        self.e = e;
        self.gap_law = false;
        self.lateral = None;
    }

    /// Any point, to be written over.
    pub fn placeholder() -> ContactPoint {
        let zero = RowVector6::zeros();
        ContactPoint::with_normal_rows(ContactGeometry::default(), None, None, zero, zero, 0.0)
    }

    /// A frictionless point whose normal rows are given (`g1`, `g2` for bodies 1 and 2);
    /// its frame is the identity and its tangential rows are zero.
    pub fn with_normal_rows(
        geometry: ContactGeometry,
        body1: BodyRef,
        body2: BodyRef,
        g1: RowVector6<f64>,
        g2: RowVector6<f64>,
        e: f64,
    ) -> ContactPoint {
        ContactPoint {
            geometry,
            frame: Matrix3::identity(),
            body1,
            body2,
            jacobian: Jacobian::Normal { g1, g2 },
            mu: 0.0,
            e,
            gap_law: false,
            lateral: None,
        }
    }

    /// The Jacobian blocks G₁, G₂ (3×6, rows n, t1, t2): the local relative velocity is
    /// G₁ v₁ + G₂ v₂ for the twists v₁, v₂ of bodies 1 and 2.
    pub fn blocks(&self) -> (Matrix3x6<f64>, Matrix3x6<f64>) {
        (self.block(0), self.block(1))
    }

    /// G₁ (`side` 0) or G₂ (`side` 1) alone: a velocity step forms only the blocks of the
    /// bodies that move.
    pub fn block(&self, side: usize) -> Matrix3x6<f64> {
        let mut g = Matrix3x6::zeros();
        match &self.jacobian {
            Jacobian::Lever { rotation, arm } => {
                g.fixed_columns_mut::<3>(0).copy_from(&self.frame);
                g.fixed_columns_mut::<3>(3)
                    .copy_from(&(self.frame * lever_of(&arm[side], &rotation[side])));
                if side == 1 {
                    g.neg_mut();
                }
            }
            Jacobian::Normal { g1, g2 } => g.row_mut(0).copy_from([g1, g2][side]),
        }
        g
    }

    /// How far the normal row has turned from `start`'s: the larger of the normal's turn
    /// and, for each moving body, the turn of the lever from its centre to the point
    /// (the change of arm × n over the arm's length).
    pub fn row_turn(&self, start: &ContactPoint) -> f64 {
        let n0 = start.frame.row(0).transpose();
        let n1 = self.frame.row(0).transpose();
        let mut turn = (n1 - n0).norm();
        if let (Jacobian::Lever { arm: a1, .. }, Jacobian::Lever { arm: a0, .. }) =
            (&self.jacobian, &start.jacobian)
        {
            for (side, body) in [self.body1, self.body2].into_iter().enumerate() {
                if body.is_none() {
                    continue;
                }
                let len = a0[side].norm().max(a1[side].norm());
                if len > 0.0 {
                    let d = (a1[side].cross(&n1) - a0[side].cross(&n0)).norm() / len;
                    turn = turn.max(d);
                }
            }
        }
        turn
    }

    /// Adds the generalized force of the local force `f` (n, t1, t2) on body 1, and its
    /// reaction on body 2, to `out` (6 entries per body): G₁ᵀ f and G₂ᵀ f.
    pub fn add_generalized(&self, f: &Vector3<f64>, out: &mut [f64]) {
        for (side, body) in [self.body1, self.body2].into_iter().enumerate() {
            if let Some(i) = body {
                let w = self.block(side).transpose() * f;
                for (o, x) in out[6 * i..6 * i + 6].iter_mut().zip(w.iter()) {
                    *o += x;
                }
            }
        }
    }

    /// The normal rows of the blocks (the gap's gradient), without the tangential ones.
    pub fn normal_rows(&self) -> (RowVector6<f64>, RowVector6<f64>) {
        match &self.jacobian {
            Jacobian::Lever { rotation, arm } => {
                let n = self.geometry.normal;
                let row = |k: usize| lever_row(&n, &lever_of(&arm[k], &rotation[k]));
                (row(0), -row(1))
            }
            Jacobian::Normal { g1, g2 } => (*g1, *g2),
        }
    }

    /// Its two bodies, the lower index first (the ground, None, lowest): the same pair
    /// whichever side the contact is seen from.
    pub fn bodies(&self) -> (BodyRef, BodyRef) {
        (self.body1.min(self.body2), self.body1.max(self.body2))
    }

    /// Local relative velocity (u_N, u_T1, u_T2) for the body twists `v` (6 per body): the
    /// frame's rows applied to the velocity of the material point of body 1 at the contact
    /// point less that of body 2, v_b + (x_b − p) × R_b ω_b for body-frame ω_b.
    pub fn local_velocity(&self, v: &[f64]) -> Vector3<f64> {
        match &self.jacobian {
            Jacobian::Lever { rotation, arm } => self.frame * self.lever_velocity(rotation, arm, v),
            Jacobian::Normal { .. } => Vector3::new(self.normal_velocity(v), 0.0, 0.0),
        }
    }

    /// u_N alone: `local_velocity(v).x`, to the bit, without the tangential rows (the
    /// activation tests and the gap laws read only it).
    pub fn normal_velocity(&self, v: &[f64]) -> f64 {
        match &self.jacobian {
            Jacobian::Lever { rotation, arm } => {
                let w = self.lever_velocity(rotation, arm, v);
                let n = |k: usize| self.frame[(0, k)];
                // the order in which the matrix product forms its first row
                n(0) * w.x + n(1) * w.y + n(2) * w.z
            }
            Jacobian::Normal { g1, g2 } => {
                let row = |g: &RowVector6<f64>, i: usize| (g * vector6_at(v, 6 * i))[0];
                self.body1.map_or(0.0, |i| row(g1, i)) + self.body2.map_or(0.0, |i| row(g2, i))
            }
        }
    }

    /// The velocity of the material point of body 1 at the contact point less that of body
    /// 2 (world frame), from the bodies' rotations and arms (`Jacobian::Lever`).
    fn lever_velocity(
        &self,
        rotation: &[Matrix3<f64>; 2],
        arm: &[Vector3<f64>; 2],
        v: &[f64],
    ) -> Vector3<f64> {
        let mut w = Vector3::zeros();
        for (k, (body, sign)) in [(self.body1, 1.0), (self.body2, -1.0)]
            .into_iter()
            .enumerate()
        {
            if let Some(i) = body {
                let (lin, ang) = (vector3_at(v, 6 * i), vector3_at(v, 6 * i + 3));
                w += (lin + arm[k].cross(&(rotation[k] * ang))) * sign;
            }
        }
        w
    }

    pub fn gap(&self) -> f64 {
        self.geometry.gap
    }

    /// Contact normal (inertial), from body 2 towards body 1.
    pub fn normal(&self) -> Vector3<f64> {
        self.geometry.normal
    }

    /// Carries the point's tangents over from `frame`, the frame of this contact at nearby
    /// poses (rows n, t1, t2): t1 is that frame's t1 less its part along this normal,
    /// t2 = n × t1. A tangent basis chosen from the normal alone jumps where the
    /// normal crosses the basis' seam (for `tangent_basis`, n_z = 0, which is every normal
    /// of a mechanism in the x–y plane), and an impulse taken along one basis and a
    /// velocity measured along the other turn friction around.
    pub fn carry_tangents_of(&mut self, frame: &Matrix3<f64>) {
        let n = self.geometry.normal;
        let t1 = frame.row(1).transpose();
        let t1 = (t1 - n * n.dot(&t1)).normalize();
        let t2 = n.cross(&t1);
        self.frame = Matrix3::from_rows(&[n.transpose(), t1.transpose(), t2.transpose()]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::{UnitQuaternion, Vector6};

    /// A plane that cannot turn (on the ground, or on a body whose rotations are held)
    /// gives the same normal at any poses, which is what lets a closed contact on it skip
    /// its mid-step and end rows; a plane on a turning body and a box's faces do not.
    #[test]
    fn only_a_plane_that_cannot_turn_has_a_fixed_normal() {
        let ball = Primitive::Sphere {
            center: Vector3::zeros(),
            radius: 0.1,
        };
        let plane = Primitive::Plane {
            point: Vector3::zeros(),
            normal: Vector3::new(0.0, 0.3, 1.0),
        };
        let cube = Primitive::Box {
            center: Vector3::zeros(),
            rotation: UnitQuaternion::identity(),
            half_extents: Vector3::new(0.5, 0.5, 0.5),
        };
        let pair = |body2: BodyRef, shape2: Primitive| {
            ContactPair::new("c", Some(0), ball.clone(), body2, shape2, 0.3, 0.0).unwrap()
        };
        // body 0 free; body 1 free (`free`) or translating only (`sliding`)
        let free = [true; 12];
        let mut sliding = [true; 12];
        sliding[9..12].fill(false);
        assert!(pair(None, plane.clone()).normal_is_fixed(&free));
        assert!(pair(Some(1), plane.clone()).normal_is_fixed(&sliding));
        assert!(!pair(Some(1), plane.clone()).normal_is_fixed(&free));
        assert!(!pair(None, cube.clone()).normal_is_fixed(&free));

        // the claim itself: the ball moved and turned, the sliding body moved
        let turned = |x: f64| Pose {
            x: Vector3::new(x, 0.2 * x, 0.3),
            p: UnitQuaternion::from_euler_angles(x, -0.5 * x, 0.2),
        };
        let a = [turned(0.1), Pose::identity()];
        let mut b = [turned(0.7), Pose::identity()];
        b[1].x = Vector3::new(0.4, -0.3, 0.2);
        for body2 in [None, Some(1)] {
            let c = pair(body2, plane.clone());
            assert_eq!(
                c.evaluate(0, &a).frame.row(0),
                c.evaluate(0, &b).frame.row(0)
            );
        }
        // a box's normal turns with the ball's place over an edge
        let c = pair(None, cube);
        let edge = |x: f64| {
            [Pose {
                x: Vector3::new(0.55, x, 0.55),
                ..Pose::identity()
            }]
        };
        assert!(
            (c.evaluate(0, &edge(0.0)).frame.row(0) - c.evaluate(0, &edge(0.6)).frame.row(0))
                .norm()
                > 0.1
        );
    }

    /// Tangents carried over from a frame whose normal lies on the other side of
    /// `tangent_basis`'s seam (n_z = ±1e-12, a mechanism in the x–y plane): the basis built
    /// from the normal alone turns by 180° about it, the carried one stays within the
    /// normal's own turn of the start's; and the Jacobian is the one built on those tangents.
    #[test]
    fn tangents_carried_across_the_basis_seam_stay_put() {
        let body = BodyFrame::new(&Pose {
            x: Vector3::new(0.1, -0.2, 0.3),
            p: UnitQuaternion::from_euler_angles(0.3, -0.2, 0.7),
        });
        let point = |normal: Vector3<f64>, tangents| {
            let g = ContactGeometry {
                gap: 0.0,
                normal,
                point1: Vector3::new(0.15, -0.1, 0.3),
                point2: Vector3::new(0.15, -0.1, 0.3),
            };
            ContactPoint::new(g, Some(0), &body, None, &body, tangents, 0.3, 0.0)
        };
        let start = point(Vector3::new(1.0, 0.0, -1e-12).normalize(), None);
        let turn = 0.01f64;
        let n = Vector3::new(turn.cos(), turn.sin(), 1e-12).normalize();
        let own = point(n, None);
        assert!(
            (own.frame.row(1) - start.frame.row(1)).norm() > 1.9,
            "no seam crossed"
        );
        let mut carried = own;
        carried.carry_tangents_of(&start.frame);
        assert!((carried.frame.row(1) - start.frame.row(1)).norm() < 1.5 * turn);
        assert!((carried.frame.row(2) - start.frame.row(2)).norm() < 1.5 * turn);
        assert_relative_eq!(
            carried.frame * carried.frame.transpose(),
            Matrix3::identity(),
            epsilon = 1e-14
        );
        let t1 = carried.frame.row(1).transpose();
        let t2 = carried.frame.row(2).transpose();
        let built = point(n, Some((t1, t2)));
        assert_relative_eq!(carried.blocks().0, built.blocks().0, epsilon = 1e-14);
        assert_relative_eq!(carried.frame, built.frame, epsilon = 1e-15);
    }

    /// The Jacobian maps twists to the relative velocity of the contact point on body 1
    /// with respect to the material point of body 2 at the same place, by finite
    /// differences of the contact point positions.
    #[test]
    fn jacobian_matches_finite_differences_of_material_points() {
        let pair = ContactPair::new(
            "c",
            Some(0),
            Primitive::Sphere {
                center: Vector3::new(0.01, 0.02, 0.0),
                radius: 0.1,
            },
            Some(1),
            Primitive::Sphere {
                center: Vector3::zeros(),
                radius: 0.2,
            },
            0.3,
            0.5,
        )
        .unwrap();
        let poses = [
            Pose {
                x: Vector3::new(0.1, 0.25, 0.2),
                p: UnitQuaternion::from_euler_angles(0.2, 0.1, -0.4),
            },
            Pose {
                x: Vector3::new(-0.1, 0.0, 0.05),
                p: UnitQuaternion::from_euler_angles(-0.3, 0.5, 0.9),
            },
        ];
        let cp = pair.evaluate(0, &poses);
        let v = [
            0.3, -0.2, 0.1, 1.0, -2.0, 0.5, -0.4, 0.2, 0.6, 0.7, 0.1, -1.3,
        ];
        let u = cp.local_velocity(&v);
        // material points of each body at the current contact point 1
        let x = cp.geometry.point1;
        let loc: Vec<Vector3<f64>> = poses.iter().map(|p| p.local(&x)).collect();
        let eps = 1e-7;
        let moved: Vec<Vector3<f64>> = (0..2)
            .map(|b| {
                let tw = Vector6::from_column_slice(&v[6 * b..6 * b + 6]) * eps;
                poses[b].advanced(&tw).point(&loc[b])
            })
            .collect();
        let rel = (moved[0] - moved[1]) / eps;
        assert_relative_eq!(u, cp.frame * rel, epsilon = 1e-6);
        // the blocks, built when asked, measure the same velocity, and their first rows are
        // the normal rows
        let (g1, g2) = cp.blocks();
        let by_blocks =
            g1 * Vector6::from_column_slice(&v[..6]) + g2 * Vector6::from_column_slice(&v[6..]);
        assert_relative_eq!(by_blocks, u, epsilon = 1e-14);
        let (n1, n2) = cp.normal_rows();
        assert_relative_eq!(n1, g1.row(0).into_owned(), epsilon = 1e-15);
        assert_relative_eq!(n2, g2.row(0).into_owned(), epsilon = 1e-15);
        // u_N alone is the full velocity's first entry, to the bit, for levers and given rows
        assert_eq!(cp.normal_velocity(&v).to_bits(), u.x.to_bits());
        let rows = ContactPoint::with_normal_rows(cp.geometry, Some(0), Some(1), n1, n2, 0.0);
        let given = rows.local_velocity(&v);
        assert_eq!(rows.normal_velocity(&v).to_bits(), given.x.to_bits());
        assert_relative_eq!(given.x, u.x, epsilon = 1e-14);
        assert_relative_eq!(
            cp.gap(),
            (poses[0].point(&Vector3::new(0.01, 0.02, 0.0)) - poses[1].x).norm() - 0.3,
            epsilon = 1e-15
        );
    }
}
