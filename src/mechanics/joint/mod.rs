//! Ideal bilateral joints: revolute, prismatic, spherical and fixed, between two bodies or
//! a body and the ground, with an optional drive (prescribed angle/position or torque/force)
//! on revolute and prismatic joints.
//!
//! Each joint yields bilateral rows h(q) = 0 with their exact gradients in twist
//! coordinates (so H v is ḣ): used as velocity rows H v = b(t) in the one-step problem and
//! as position rows in the projection.

mod profile;

pub use profile::ScalarProfile;

use crate::math::{any_orthogonal, skew};
use crate::mechanics::body::BodyRef;
use crate::mechanics::body::{pose_of, Pose};
use crate::mechanics::contact::{ContactGeometry, ContactPoint};
use nalgebra::{Matrix3, RowVector6, Vector3};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointKind {
    /// Common point and common axis: 5 rows, rotation about the axis free.
    Revolute,
    /// Common orientation, anchor of b on a's axis line: 5 rows, sliding along the axis.
    Prismatic,
    /// Common point: 3 rows.
    Spherical,
    /// Common point and orientation: 6 rows.
    Fixed,
}

impl JointKind {
    pub fn name(&self) -> &'static str {
        match self {
            JointKind::Revolute => "revolute",
            JointKind::Prismatic => "prismatic",
            JointKind::Spherical => "spherical",
            JointKind::Fixed => "fixed",
        }
    }
}

/// What drives the joint's coordinate (angle for revolute, displacement for prismatic),
/// measured from the assembled configuration.
#[derive(Clone, Debug, PartialEq)]
pub enum Drive {
    /// Prescribed coordinate q(t): one more bilateral row (rheonomic).
    Position(ScalarProfile),
    /// Prescribed generalized force (torque about, or force along, the axis) on b, −on a.
    Effort(ScalarProfile),
}

#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    pub name: String,
    pub kind: JointKind,
    pub a: BodyRef,
    pub b: BodyRef,
    /// Anchor point in each body's frame.
    pub anchor_a: Vector3<f64>,
    pub anchor_b: Vector3<f64>,
    /// Unit axis in each body's frame (aligned at assembly).
    pub axis_a: Vector3<f64>,
    pub axis_b: Vector3<f64>,
    /// Unit vectors ⟂ axis in a's frame, (axis, perp1, perp2) right-handed.
    perp_a: [Vector3<f64>; 2],
    /// perp1 of a expressed in b's frame at assembly (zero angle reference).
    ref_b: Vector3<f64>,
    pub drive: Option<Drive>,
    /// Stops on the joint coordinate: frictionless unilateral contacts.
    pub limits: Option<JointLimits>,
}

/// Lower and upper stop of a joint coordinate (rad or m), with the restitution of the
/// stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointLimits {
    pub lower: f64,
    pub upper: f64,
    pub e: f64,
}

/// Whether a row measures a length (m) or an angle (rad), for diagnostics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowUnit {
    Length,
    Angle,
}

/// One bilateral row: value h(q), gradient blocks per body (twist coordinates) and the
/// prescribed rate ḣ target (0 unless driven).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BilateralRow {
    pub a: Option<(usize, RowVector6<f64>)>,
    pub b: Option<(usize, RowVector6<f64>)>,
    pub value: f64,
    pub rate: f64,
    pub unit: RowUnit,
}

/// A blank row pushed onto `out`, to be filled where it lies.
fn blank(out: &mut Vec<BilateralRow>) -> &mut BilateralRow {
    out.push(BilateralRow {
        a: None,
        b: None,
        value: 0.0,
        rate: 0.0,
        unit: RowUnit::Length,
    });
    out.last_mut().expect("a row was just pushed")
}

impl Joint {
    /// Builds a joint from the anchor and axis given in world coordinates at the assembled
    /// configuration `poses`.
    #[allow(clippy::too_many_arguments)]
    pub fn from_world(
        name: impl Into<String>,
        kind: JointKind,
        a: BodyRef,
        b: BodyRef,
        anchor: Vector3<f64>,
        axis: Vector3<f64>,
        poses: &[Pose],
        drive: Option<Drive>,
    ) -> Joint {
        let pa = pose_of(a, poses);
        let pb = pose_of(b, poses);
        let axis = axis.normalize();
        Joint::new(
            name,
            kind,
            a,
            b,
            pa.local(&anchor),
            pb.local(&anchor),
            pa.p.inverse_transform_vector(&axis),
            pb.p.inverse_transform_vector(&axis),
            poses,
            drive,
        )
    }

    /// Builds a joint from body-frame anchors and axes; the zero of the joint coordinate
    /// is the configuration `poses`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        name: impl Into<String>,
        kind: JointKind,
        a: BodyRef,
        b: BodyRef,
        anchor_a: Vector3<f64>,
        anchor_b: Vector3<f64>,
        axis_a: Vector3<f64>,
        axis_b: Vector3<f64>,
        poses: &[Pose],
        drive: Option<Drive>,
    ) -> Joint {
        let axis_a = axis_a.normalize();
        let axis_b = axis_b.normalize();
        let p1 = any_orthogonal(&axis_a);
        let p2 = axis_a.cross(&p1);
        let pa = pose_of(a, poses);
        let pb = pose_of(b, poses);
        let ref_b = pb.p.inverse_transform_vector(&pa.dir(&p1));
        Joint {
            name: name.into(),
            kind,
            a,
            b,
            anchor_a,
            anchor_b,
            axis_a,
            axis_b,
            perp_a: [p1, p2],
            ref_b,
            drive,
            limits: None,
        }
    }

    pub fn with_limits(mut self, limits: JointLimits) -> Self {
        self.limits = Some(limits);
        self
    }

    /// The joint coordinate (see [`Joint::coordinate`]) as a row with its gradient.
    pub fn coordinate_row(&self, poses: &[Pose]) -> BilateralRow {
        let pa = pose_of(self.a, poses);
        let pb = pose_of(self.b, poses);
        let ra = pa.p.to_rotation_matrix().into_inner();
        let rb = pb.p.to_rotation_matrix().into_inner();
        let mut ga = RowVector6::zeros();
        let mut gb = RowVector6::zeros();
        let unit = match self.kind {
            JointKind::Prismatic => {
                // s = e·(x_b − x_a) with e = R_a axis_a
                let e = pa.dir(&self.axis_a);
                let xa = pa.point(&self.anchor_a);
                let xb = pb.point(&self.anchor_b);
                gb.fixed_columns_mut::<3>(0).copy_from(&e.transpose());
                gb.fixed_columns_mut::<3>(3)
                    .copy_from(&(-e.transpose() * skew(&(xb - pb.x)) * rb));
                ga.fixed_columns_mut::<3>(0).copy_from(&(-e.transpose()));
                ga.fixed_columns_mut::<3>(3).copy_from(
                    &((e.transpose() * skew(&(xa - pa.x)) + e.cross(&(xb - xa)).transpose()) * ra),
                );
                RowUnit::Length
            }
            _ => {
                // φ = atan2(r·p2, r·p1), r = R_b ref_b: φ̇ = (ω_b − ω_a)·c (c = axis when aligned)
                let r = pb.dir(&self.ref_b);
                let (p1, p2) = (pa.dir(&self.perp_a[0]), pa.dir(&self.perp_a[1]));
                let (c1, c2) = (r.dot(&p1), r.dot(&p2));
                let c = (r.cross(&p2) * c1 - r.cross(&p1) * c2) / (c1 * c1 + c2 * c2);
                gb.fixed_columns_mut::<3>(3)
                    .copy_from(&(c.transpose() * rb));
                ga.fixed_columns_mut::<3>(3)
                    .copy_from(&(-c.transpose() * ra));
                RowUnit::Angle
            }
        };
        BilateralRow {
            a: self.a.map(|i| (i, ga)),
            b: self.b.map(|i| (i, gb)),
            value: self.coordinate(poses),
            rate: 0.0,
            unit,
        }
    }

    /// The lower (or upper) stop as a frictionless contact point: gap q − lower (or
    /// upper − q), normal row ±∂q/∂ν, no tangential rows.
    pub fn limit_point(&self, upper: bool, poses: &[Pose]) -> ContactPoint {
        let lim = self.limits.expect("limit_point on a joint with limits");
        let row = self.coordinate_row(poses);
        let (sign, gap) = if upper {
            (-1.0, lim.upper - row.value)
        } else {
            (1.0, row.value - lim.lower)
        };
        let normal_row =
            |g: Option<(usize, RowVector6<f64>)>| g.map_or(RowVector6::zeros(), |(_, r)| r * sign);
        let pa = pose_of(self.a, poses);
        let pb = pose_of(self.b, poses);
        ContactPoint::with_normal_rows(
            ContactGeometry {
                gap,
                normal: pa.dir(&self.axis_a) * sign,
                point1: pb.point(&self.anchor_b),
                point2: pa.point(&self.anchor_a),
            },
            self.b,
            self.a,
            normal_row(row.b),
            normal_row(row.a),
            lim.e,
        )
    }

    /// Joint coordinate: the angle of b about the axis (revolute) or the displacement of
    /// b's anchor along the axis (prismatic), from the assembled configuration.
    pub fn coordinate(&self, poses: &[Pose]) -> f64 {
        let pa = pose_of(self.a, poses);
        let pb = pose_of(self.b, poses);
        match self.kind {
            JointKind::Prismatic => pa
                .dir(&self.axis_a)
                .dot(&(pb.point(&self.anchor_b) - pa.point(&self.anchor_a))),
            _ => {
                let r = pb.dir(&self.ref_b);
                r.dot(&pa.dir(&self.perp_a[1]))
                    .atan2(r.dot(&pa.dir(&self.perp_a[0])))
            }
        }
    }

    /// Number of bilateral rows (including a position drive).
    pub fn row_count(&self) -> usize {
        let base = match self.kind {
            JointKind::Revolute | JointKind::Prismatic => 5,
            JointKind::Spherical => 3,
            JointKind::Fixed => 6,
        };
        base + usize::from(matches!(self.drive, Some(Drive::Position(_))))
    }

    /// Appends the joint's rows at time `t` and poses `poses`.
    pub fn rows(&self, t: f64, poses: &[Pose], out: &mut Vec<BilateralRow>) {
        self.rows_of(t, poses, true, out);
    }

    /// Appends the joint's rows without their gradients (`a` and `b` are `None`): their
    /// values, bit for bit those of `rows`, are all that a test of the violation reads, and
    /// they cost a fraction of the rotations and products the gradients take.
    pub fn row_values(&self, t: f64, poses: &[Pose], out: &mut Vec<BilateralRow>) {
        self.rows_of(t, poses, false, out);
    }

    fn rows_of(&self, t: f64, poses: &[Pose], gradients: bool, out: &mut Vec<BilateralRow>) {
        let pa = pose_of(self.a, poses);
        let pb = pose_of(self.b, poses);
        // On the ground, whose frame is the world's, a point and a direction are their
        // local coordinates: turning them by the identity gives them back (a zero
        // coordinate perhaps with the other sign), but costs a quaternion product each.
        // Adding the zero origin gives a point's zeros the sign `point` leaves them.
        let xa = match self.a {
            Some(_) => pa.point(&self.anchor_a),
            None => Vector3::zeros() + self.anchor_a,
        };
        let xb = pb.point(&self.anchor_b);
        let d = xb - xa;
        // each body's rotation and the lever of its anchor; the ground has no blocks
        let frame = |r: BodyRef, pose: &Pose, x: &Vector3<f64>| {
            r.filter(|_| gradients).map(|i| {
                let rot = pose.p.to_rotation_matrix().into_inner();
                (i, rot, skew(&(x - pose.x)) * rot)
            })
        };
        let on_a = frame(self.a, pa, &xa);
        let on_b = frame(self.b, pb, &xb);
        // Each row is pushed blank and filled where it lies: a row of 152 bytes built aside
        // and copied in is read back while its stores are still in flight.
        let translation = |e: Vector3<f64>, carried_by_a: bool, row: &mut BilateralRow| {
            translation_row(e, carried_by_a, &d, &on_a, &on_b, row)
        };
        // x·y with x = R_a X (on a), y = R_b Y (on b): ḣ = (ω_b − ω_a)·(y × x)
        let angular = |x: Vector3<f64>, y: Vector3<f64>, row: &mut BilateralRow| {
            let c = y.cross(&x);
            row.b = on_b.map(|(i, rb, _)| {
                let mut gb = RowVector6::zeros();
                gb.fixed_columns_mut::<3>(3)
                    .copy_from(&(c.transpose() * rb));
                (i, gb)
            });
            row.a = on_a.map(|(i, ra, _)| {
                let mut ga = RowVector6::zeros();
                ga.fixed_columns_mut::<3>(3)
                    .copy_from(&(-c.transpose() * ra));
                (i, ga)
            });
            row.value = x.dot(&y);
            row.unit = RowUnit::Angle;
        };
        // a's two perpendiculars in the world, turned once, for every kind but the
        // spherical joint, which does not use them
        let perp = (self.kind != JointKind::Spherical).then(|| match self.a {
            Some(_) => (pa.dir(&self.perp_a[0]), pa.dir(&self.perp_a[1])),
            None => (self.perp_a[0], self.perp_a[1]),
        });
        match self.kind {
            JointKind::Spherical | JointKind::Revolute | JointKind::Fixed => {
                for e in [Vector3::x(), Vector3::y(), Vector3::z()] {
                    translation(e, false, blank(out));
                }
            }
            JointKind::Prismatic => {
                let (p1, p2) = perp.expect("a prismatic joint's perpendiculars");
                translation(p1, true, blank(out));
                translation(p2, true, blank(out));
            }
        }
        if let Some((p1, p2)) = perp {
            let axis_b = pb.dir(&self.axis_b);
            angular(p1, axis_b, blank(out));
            angular(p2, axis_b, blank(out));
            if matches!(self.kind, JointKind::Fixed | JointKind::Prismatic) {
                angular(p2, pb.dir(&self.ref_b), blank(out));
            }
        }
        if let Some(Drive::Position(profile)) = &self.drive {
            let target = profile.value(t);
            let rate = profile.rate(t);
            let r = blank(out);
            match self.kind {
                JointKind::Prismatic => {
                    translation(pa.dir(&self.axis_a), true, r);
                    r.value -= target;
                }
                _ => {
                    match gradients {
                        true => *r = self.coordinate_row(poses),
                        false => {
                            r.value = self.coordinate(poses);
                            r.unit = RowUnit::Angle;
                        }
                    }
                    // angle error wrapped to (−π, π]
                    let err = r.value - target;
                    r.value = (err + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI)
                        - std::f64::consts::PI;
                }
            }
            r.rate = rate;
        }
    }

    /// Adds the wrench of an effort drive (torque about / force along the axis) at time t.
    pub fn apply_effort(&self, t: f64, poses: &[Pose], out: &mut [f64]) {
        let Some(Drive::Effort(profile)) = &self.drive else {
            return;
        };
        let effort = profile.value(t);
        let pa = pose_of(self.a, poses);
        let pb = pose_of(self.b, poses);
        let axis = pa.dir(&self.axis_a) * effort;
        let mut add = |r: BodyRef, pose: &Pose, sign: f64| {
            if let Some(i) = r {
                match self.kind {
                    JointKind::Prismatic => {
                        let x = if r == self.a {
                            pa.point(&self.anchor_a)
                        } else {
                            pb.point(&self.anchor_b)
                        };
                        let f = axis * sign;
                        let tq = pose.p.inverse_transform_vector(&(x - pose.x).cross(&f));
                        for k in 0..3 {
                            out[6 * i + k] += f[k];
                            out[6 * i + 3 + k] += tq[k];
                        }
                    }
                    _ => {
                        let tq = pose.p.inverse_transform_vector(&(axis * sign));
                        for k in 0..3 {
                            out[6 * i + 3 + k] += tq[k];
                        }
                    }
                }
            }
        };
        add(self.b, pb, 1.0);
        add(self.a, pa, -1.0);
    }
}

/// A body's index, rotation and the lever of its anchor, for the rows' gradients.
type OnBody = Option<(usize, Matrix3<f64>, Matrix3<f64>)>;

/// The row e·(x_b − x_a) = e·d for a world direction e carried by a (`carried_by_a`) or
/// the ground, filled in `row` where it lies. Inlined: called as a closure, it ran as a
/// call per row.
#[inline(always)]
fn translation_row(
    e: Vector3<f64>,
    carried_by_a: bool,
    d: &Vector3<f64>,
    on_a: &OnBody,
    on_b: &OnBody,
    row: &mut BilateralRow,
) {
    row.b = on_b.map(|(i, _, lever_b)| {
        let mut gb = RowVector6::zeros();
        gb.fixed_columns_mut::<3>(0).copy_from(&e.transpose());
        gb.fixed_columns_mut::<3>(3)
            .copy_from(&(-e.transpose() * lever_b));
        (i, gb)
    });
    row.a = on_a.map(|(i, ra, lever_a)| {
        let mut ga = RowVector6::zeros();
        ga.fixed_columns_mut::<3>(0).copy_from(&(-e.transpose()));
        let mut rot = e.transpose() * lever_a;
        if carried_by_a {
            rot += e.cross(d).transpose() * ra;
        }
        ga.fixed_columns_mut::<3>(3).copy_from(&rot);
        (i, ga)
    });
    row.value = e.dot(d);
    row.unit = RowUnit::Length;
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{UnitQuaternion, Vector6};

    /// A joint of `kind` between bodies 0 and 1, anchors off their centres, axis z.
    fn test_joint(kind: JointKind, assembled: &[Pose], drive: Option<Drive>) -> Joint {
        Joint::new(
            "j",
            kind,
            Some(0),
            Some(1),
            Vector3::new(0.1, 0.2, 0.0),
            Vector3::new(-0.1, 0.0, 0.05),
            Vector3::new(0.0, 0.0, 1.0),
            Vector3::new(0.0, 0.0, 1.0),
            assembled,
            drive,
        )
    }

    /// Every kind of joint.
    const KINDS: [JointKind; 4] = [
        JointKind::Revolute,
        JointKind::Prismatic,
        JointKind::Spherical,
        JointKind::Fixed,
    ];

    /// A position drive whose profile moves, from t = 0.1 at 2 a second.
    fn moving_drive() -> Drive {
        Drive::Position(ScalarProfile::Rate {
            start: 0.1,
            rate: 2.0,
        })
    }

    /// Two bodies turned and moved off any joint's assembled configuration.
    fn off_assembly() -> Vec<Pose> {
        vec![
            Pose {
                x: Vector3::new(0.1, -0.2, 0.3),
                p: UnitQuaternion::from_euler_angles(0.2, -0.3, 0.4),
            },
            Pose {
                x: Vector3::new(0.5, 0.1, -0.1),
                p: UnitQuaternion::from_euler_angles(-0.1, 0.25, 1.0),
            },
        ]
    }

    /// Every row's gradient is the derivative of its value along any twist (finite
    /// differences through the Lie-group update), at a configuration off the manifold.
    #[test]
    fn row_gradients_match_finite_differences() {
        let poses = off_assembly();
        for kind in KINDS {
            let assembled = vec![
                poses[0],
                Pose {
                    x: poses[1].x,
                    p: poses[0].p,
                },
            ];
            let j = test_joint(
                kind,
                &assembled,
                Some(Drive::Position(ScalarProfile::Rate {
                    start: 0.0,
                    rate: 0.0,
                })),
            );
            let mut rows = Vec::new();
            j.rows(0.0, &poses, &mut rows);
            assert_eq!(rows.len(), j.row_count());
            let tw = [
                Vector6::new(0.3, -0.1, 0.2, 0.5, -0.7, 0.2),
                Vector6::new(-0.2, 0.4, 0.1, -0.3, 0.6, 0.9),
            ];
            let eps = 1e-7;
            let moved: Vec<Pose> = (0..2).map(|i| poses[i].advanced(&(tw[i] * eps))).collect();
            let back: Vec<Pose> = (0..2).map(|i| poses[i].advanced(&(tw[i] * -eps))).collect();
            let (mut r1, mut r0) = (Vec::new(), Vec::new());
            j.rows(0.0, &moved, &mut r1);
            j.rows(0.0, &back, &mut r0);
            for (k, row) in rows.iter().enumerate() {
                let analytic = row.a.unwrap().1.dot(&tw[0].transpose())
                    + row.b.unwrap().1.dot(&tw[1].transpose());
                let fd = (r1[k].value - r0[k].value) / (2.0 * eps);
                assert!(
                    (analytic - fd).abs() < 1e-7,
                    "{kind:?} row {k}: analytic {analytic} vs fd {fd}"
                );
            }
        }
    }

    /// `row_values` gives the rows of `rows`, values, rates and units bit for bit, without
    /// their gradients: for every kind, with a position drive at a time where its profile
    /// moves, and with the ground as either body.
    #[test]
    fn row_values_are_the_rows_without_gradients() {
        let poses = off_assembly();
        let drive = moving_drive();
        for kind in KINDS {
            for (a, b) in [(Some(0), Some(1)), (None, Some(1)), (Some(0), None)] {
                let mut j = test_joint(kind, &[Pose::identity(); 2], Some(drive.clone()));
                (j.a, j.b) = (a, b);
                let (mut rows, mut values) = (Vec::new(), Vec::new());
                j.rows(0.3, &poses, &mut rows);
                j.row_values(0.3, &poses, &mut values);
                assert_eq!(values.len(), rows.len(), "{kind:?}");
                for (r, v) in rows.iter().zip(&values) {
                    assert_eq!(r.value.to_bits(), v.value.to_bits(), "{kind:?}");
                    assert_eq!(r.rate.to_bits(), v.rate.to_bits(), "{kind:?}");
                    assert_eq!(r.unit, v.unit, "{kind:?}");
                    assert_eq!((r.a.is_some(), r.b.is_some()), (a.is_some(), b.is_some()));
                    assert!(v.a.is_none() && v.b.is_none(), "{kind:?}");
                }
                assert!(rows.iter().any(|r| r.value != 0.0 && r.rate != 0.0));
            }
        }
    }

    /// A joint on the ground has the rows of the same joint on a body held at the
    /// identity: values, rates and body b's gradients, for every kind with a drive (the
    /// ground's points and directions are taken as they are, not turned).
    #[test]
    fn rows_on_the_ground_are_those_on_a_body_at_the_identity() {
        let poses = vec![Pose::identity(), off_assembly()[1]];
        let drive = moving_drive();
        for kind in KINDS {
            let on_body = test_joint(kind, &off_assembly(), Some(drive.clone()));
            let mut on_ground = on_body.clone();
            on_ground.a = None;
            let (mut rows, mut ground_rows) = (Vec::new(), Vec::new());
            on_body.rows(0.3, &poses, &mut rows);
            on_ground.rows(0.3, &poses, &mut ground_rows);
            assert_eq!(rows.len(), ground_rows.len(), "{kind:?}");
            for (r, g) in rows.iter().zip(&ground_rows) {
                assert_eq!(
                    (r.value, r.rate, r.unit),
                    (g.value, g.rate, g.unit),
                    "{kind:?}"
                );
                assert_eq!(r.b, g.b, "{kind:?}");
                assert!(r.a.is_some() && g.a.is_none(), "{kind:?}");
            }
            assert!(
                rows.iter().filter(|r| r.value.abs() > 1e-3).count() >= 2,
                "{kind:?}"
            );
        }
    }

    /// A stop is a contact point whose normal speed is the rate at which its gap closes:
    /// d(q − lower)/dt at the lower stop, d(upper − q)/dt at the upper one, by finite
    /// differences of the gap along a twist; it has no tangential rows.
    #[test]
    fn stop_speed_is_the_rate_of_its_gap() {
        let assembled = vec![Pose::identity(), Pose::identity()];
        let mut j = test_joint(JointKind::Revolute, &assembled, None);
        j.limits = Some(JointLimits {
            lower: -0.5,
            upper: 0.8,
            e: 0.3,
        });
        let poses = [
            Pose {
                x: Vector3::new(0.0, 0.1, 0.0),
                p: UnitQuaternion::from_euler_angles(0.02, -0.01, 0.1),
            },
            Pose {
                x: Vector3::new(0.2, 0.1, 0.0),
                p: UnitQuaternion::from_euler_angles(-0.01, 0.03, 0.4),
            },
        ];
        let tw = [
            Vector6::new(0.3, -0.1, 0.2, 0.5, -0.7, 0.2),
            Vector6::new(-0.2, 0.4, 0.1, -0.3, 0.6, 0.9),
        ];
        let v: Vec<f64> = tw.iter().flat_map(|t| t.iter().copied()).collect();
        let eps = 1e-7;
        let at =
            |s: f64| -> Vec<Pose> { (0..2).map(|i| poses[i].advanced(&(tw[i] * s))).collect() };
        for upper in [false, true] {
            let cp = j.limit_point(upper, &poses);
            let fd = (j.limit_point(upper, &at(eps)).gap() - j.limit_point(upper, &at(-eps)).gap())
                / (2.0 * eps);
            let u = cp.local_velocity(&v);
            assert!((u.x - fd).abs() < 1e-7, "upper {upper}: {} vs {fd}", u.x);
            assert_eq!((u.y, u.z), (0.0, 0.0));
            let (g1, g2) = cp.blocks();
            let by_blocks = g1 * tw[1] + g2 * tw[0];
            assert!((by_blocks - u).norm() < 1e-14);
            assert_eq!(
                cp.normal_rows(),
                (g1.row(0).into_owned(), g2.row(0).into_owned())
            );
        }
    }

    #[test]
    fn revolute_coordinate_is_the_relative_angle() {
        let rz = |a: f64| UnitQuaternion::from_euler_angles(0.0, 0.0, a);
        let assembled = vec![
            Pose {
                x: Vector3::zeros(),
                p: rz(0.3),
            },
            Pose {
                x: Vector3::x(),
                p: rz(0.3),
            },
        ];
        let j = Joint::from_world(
            "j",
            JointKind::Revolute,
            Some(0),
            Some(1),
            Vector3::zeros(),
            Vector3::z(),
            &assembled,
            None,
        );
        let turned = vec![
            assembled[0],
            Pose {
                x: Vector3::x(),
                p: rz(1.5),
            },
        ];
        assert!((j.coordinate(&turned) - 1.2).abs() < 1e-14);
        let mut rows = Vec::new();
        j.rows(0.0, &assembled, &mut rows);
        assert!(
            rows[3..].iter().all(|r| r.value.abs() < 1e-15),
            "aligned axes: zero angular rows"
        );
        assert!(
            rows[..3].iter().all(|r| r.value.abs() < 1e-15),
            "anchors coincide at assembly"
        );
    }
}
