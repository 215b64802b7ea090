//! Validation of a parsed scene into a model: every check names the field and its line.

use super::error::{line, SceneError};
use super::schema::*;
use super::units::{Dim, Quantity};
use super::Scene;
use crate::integrator::{IntegrationParameters, Preset, Scheme};
use crate::mechanics::contact::clearance::ClearanceJoint;
use crate::mechanics::force::{ExternalLoad, Frame, PointSpring, TorsionalSpring};
use crate::mechanics::joint::{Drive, Joint, JointKind, JointLimits, ScalarProfile};
use crate::mechanics::{
    BodyRef, ContactPair, Force, Model, Motion, Primitive, Profile, Refine, RigidBody, Settle,
    Shape,
};
use nalgebra::{Matrix3, Quaternion, Unit, UnitQuaternion, Vector3};
use serde_saphyr::Spanned;

type R<T> = Result<T, SceneError>;

pub(super) fn scalar(q: &Q, dim: Dim, field: &str) -> R<f64> {
    let v = q
        .value
        .value(dim)
        .map_err(|m| SceneError::at(line(q), field, m))?;
    if !v.is_finite() {
        return Err(SceneError::at(line(q), field, "must be a finite number"));
    }
    Ok(v)
}

fn positive(q: &Q, dim: Dim, field: &str) -> R<f64> {
    let v = scalar(q, dim, field)?;
    if v <= 0.0 {
        return Err(SceneError::at(
            line(q),
            field,
            format!("must be positive, got {v}"),
        ));
    }
    Ok(v)
}

/// An optional preload ramp time (≥ 0; default 0, no ramp).
fn ramp(q: &Option<Q>, field: &str) -> R<f64> {
    q.as_ref()
        .map_or(Ok(0.0), |q| non_negative(q, Dim::TIME, field))
}

fn non_negative(q: &Q, dim: Dim, field: &str) -> R<f64> {
    let v = scalar(q, dim, field)?;
    if v < 0.0 {
        return Err(SceneError::at(
            line(q),
            field,
            format!("must be ≥ 0, got {v}"),
        ));
    }
    Ok(v)
}

fn values(v: &Vector, dim: Dim, field: &str, len: usize) -> R<Vec<f64>> {
    if v.value.len() != len {
        return Err(SceneError::at(
            line(v),
            field,
            format!("needs {len} components, got {}", v.value.len()),
        ));
    }
    v.value
        .iter()
        .map(|q: &Quantity| {
            let x = q
                .value(dim)
                .map_err(|m| SceneError::at(line(v), field, m))?;
            if x.is_finite() {
                Ok(x)
            } else {
                Err(SceneError::at(line(v), field, "must hold finite numbers"))
            }
        })
        .collect()
}

/// A Newton restitution coefficient: in [0, 1], default 0.
fn restitution(q: &Option<Q>, field: &str) -> R<f64> {
    let Some(q) = q else { return Ok(0.0) };
    let e = scalar(q, Dim::NONE, field)?;
    if !(0.0..=1.0).contains(&e) {
        return Err(SceneError::at(
            line(q),
            field,
            format!("must be in [0, 1], got {e}"),
        ));
    }
    Ok(e)
}

fn vec3(v: &Vector, dim: Dim, field: &str) -> R<Vector3<f64>> {
    let x = values(v, dim, field, 3)?;
    Ok(Vector3::new(x[0], x[1], x[2]))
}

pub(super) fn opt_vec3(v: &Option<Vector>, dim: Dim, field: &str) -> R<Vector3<f64>> {
    v.as_ref()
        .map_or(Ok(Vector3::zeros()), |v| vec3(v, dim, field))
}

pub(super) fn unit_vec3(v: &Vector, field: &str) -> R<Vector3<f64>> {
    let x = vec3(v, Dim::NONE, field)?;
    let n = x.norm();
    if n == 0.0 {
        return Err(SceneError::at(
            line(v),
            field,
            "must not be the zero vector",
        ));
    }
    Ok(x / n)
}

fn orientation(o: &Spanned<OrientationSpec>, field: &str) -> R<UnitQuaternion<f64>> {
    let s = &o.value;
    let given = [
        s.axis.is_some() || s.angle.is_some(),
        s.quaternion.is_some(),
        s.rotation_vector.is_some(),
    ];
    if given.iter().filter(|&&g| g).count() != 1 {
        return Err(SceneError::at(
            line(o),
            field,
            "give exactly one of `axis` + `angle`, `quaternion` [w, x, y, z] or `rotation_vector`",
        ));
    }
    if let Some(q) = &s.quaternion {
        let x = values(q, Dim::NONE, &format!("{field}.quaternion"), 4)?;
        let quat = Quaternion::new(x[0], x[1], x[2], x[3]);
        if (quat.norm() - 1.0).abs() > 1e-6 {
            return Err(SceneError::at(
                line(q),
                format!("{field}.quaternion"),
                format!("must have unit norm (got {})", quat.norm()),
            ));
        }
        return Ok(UnitQuaternion::from_quaternion(quat));
    }
    if let Some(r) = &s.rotation_vector {
        return Ok(crate::math::expq(&vec3(
            r,
            Dim::NONE,
            &format!("{field}.rotation_vector"),
        )?));
    }
    let axis = s.axis.as_ref().ok_or_else(|| {
        SceneError::at(line(o), format!("{field}.axis"), "is required with `angle`")
    })?;
    let angle = s.angle.as_ref().ok_or_else(|| {
        SceneError::at(line(o), format!("{field}.angle"), "is required with `axis`")
    })?;
    let axis = unit_vec3(axis, &format!("{field}.axis"))?;
    Ok(UnitQuaternion::from_axis_angle(
        &Unit::new_unchecked(axis),
        scalar(angle, Dim::NONE, &format!("{field}.angle"))?,
    ))
}

pub(super) fn body_ref(model: &Model, name: &Name, field: &str) -> R<BodyRef> {
    if name.value == "ground" {
        return Ok(None);
    }
    model.body_index(&name.value).map(Some).ok_or_else(|| {
        let known: Vec<&str> = model.bodies.iter().map(|b| b.name.as_str()).collect();
        SceneError::at(
            line(name),
            field,
            format!(
                "unknown body `{}` (bodies: ground, {})",
                name.value,
                known.join(", ")
            ),
        )
    })
}

fn body(spec: &BodySpec, i: usize) -> R<RigidBody> {
    let f = |s: &str| format!("bodies[{i}].{s}");
    let name = spec.name.value.clone();
    if name.is_empty() || name == "ground" {
        return Err(SceneError::at(
            line(&spec.name),
            f("name"),
            "must be non-empty and not the reserved name `ground`",
        ));
    }
    let motion = match spec.motion.as_ref().map(|m| m.value.as_str()) {
        None | Some("free") => Motion::Free,
        Some("pinned") => Motion::Pinned,
        Some("fixed") => Motion::Fixed,
        Some(other) => {
            return Err(SceneError::at(
                spec.motion.as_ref().and_then(line),
                f("motion"),
                format!("unknown motion `{other}` (use free, pinned or fixed)"),
            ))
        }
    };
    let mut b = if motion == Motion::Fixed {
        RigidBody::fixed(name)
    } else {
        let mass_q = spec.mass.as_ref().ok_or_else(|| {
            SceneError::at(line(&spec.name), f("mass"), "is required for a moving body")
        })?;
        let mass = positive(mass_q, Dim::MASS, &f("mass"))?;
        let inertia = match (&spec.inertia, &spec.shape) {
            (Some(v), _) => {
                let m = match v.value.len() {
                    3 => Matrix3::from_diagonal(&vec3(v, Dim::INERTIA, &f("inertia"))?),
                    9 => Matrix3::from_row_slice(&values(v, Dim::INERTIA, &f("inertia"), 9)?),
                    n => {
                        return Err(SceneError::at(
                            line(v),
                            f("inertia"),
                            format!("needs 3 principal moments or 9 tensor entries, got {n}"),
                        ))
                    }
                };
                let sym = (m - m.transpose()).norm() <= 1e-12 * m.norm();
                let pd = sym && m.cholesky().is_some();
                if !pd {
                    return Err(SceneError::at(
                        line(v),
                        f("inertia"),
                        "must be symmetric positive definite",
                    ));
                }
                m
            }
            (None, Some(s)) => shape(&s.value, &f("shape"), line(s))?.inertia(mass),
            (None, None) => {
                return Err(SceneError::at(
                    line(&spec.name),
                    f("inertia"),
                    "give `inertia` or a `shape` to derive it from",
                ))
            }
        };
        RigidBody::new(name, mass, inertia).with_motion(motion)
    };
    b.pose.x = opt_vec3(&spec.position, Dim::LENGTH, &f("position"))?;
    if let Some(o) = &spec.orientation {
        b.pose.p = orientation(o, &f("orientation"))?;
    }
    if motion != Motion::Fixed {
        b.velocity = opt_vec3(&spec.velocity, Dim::VELOCITY, &f("velocity"))?;
        b.angular_velocity = opt_vec3(
            &spec.angular_velocity,
            Dim::ANGULAR_VELOCITY,
            &f("angular_velocity"),
        )?;
    }
    Ok(b)
}

fn shape(s: &ShapeSpec, field: &str, _line: Option<u64>) -> R<Shape> {
    Ok(match s {
        ShapeSpec::Box { size } => {
            let v = vec3(size, Dim::LENGTH, &format!("{field}.box.size"))?;
            if v.iter().any(|&x| x <= 0.0) {
                return Err(SceneError::at(
                    line(size),
                    format!("{field}.box.size"),
                    "must be positive",
                ));
            }
            Shape::Box { size: v }
        }
        ShapeSpec::Cylinder { radius, length } => Shape::Cylinder {
            radius: positive(radius, Dim::LENGTH, &format!("{field}.cylinder.radius"))?,
            length: positive(length, Dim::LENGTH, &format!("{field}.cylinder.length"))?,
        },
        ShapeSpec::Sphere { radius } => Shape::Sphere {
            radius: positive(radius, Dim::LENGTH, &format!("{field}.sphere.radius"))?,
        },
    })
}

fn primitive(p: &Spanned<PrimitiveSpec>, field: &str) -> R<Primitive> {
    let fl = |s: &str| format!("{field}.{s}");
    let axis_of = |a: &Option<Vector>, name: &str| -> R<Vector3<f64>> {
        a.as_ref()
            .map_or(Ok(Vector3::z()), |a| unit_vec3(a, &fl(name)))
    };
    Ok(match &p.value {
        PrimitiveSpec::Sphere { radius, center } => Primitive::Sphere {
            radius: positive(radius, Dim::LENGTH, &fl("sphere.radius"))?,
            center: opt_vec3(center, Dim::LENGTH, &fl("sphere.center"))?,
        },
        PrimitiveSpec::Plane { point, normal } => Primitive::Plane {
            point: opt_vec3(point, Dim::LENGTH, &fl("plane.point"))?,
            normal: unit_vec3(normal, &fl("plane.normal"))?,
        },
        PrimitiveSpec::Box {
            size,
            center,
            orientation: o,
        } => {
            let s = vec3(size, Dim::LENGTH, &fl("box.size"))?;
            if s.iter().any(|&x| x <= 0.0) {
                return Err(SceneError::at(
                    line(size),
                    fl("box.size"),
                    "must be positive",
                ));
            }
            Primitive::Box {
                half_extents: s * 0.5,
                center: opt_vec3(center, Dim::LENGTH, &fl("box.center"))?,
                rotation: o.as_ref().map_or(Ok(UnitQuaternion::identity()), |o| {
                    orientation(o, &fl("box.orientation"))
                })?,
            }
        }
        PrimitiveSpec::Cylinder {
            radius,
            length,
            axis,
            center,
        } => Primitive::Cylinder {
            radius: positive(radius, Dim::LENGTH, &fl("cylinder.radius"))?,
            half_length: 0.5 * positive(length, Dim::LENGTH, &fl("cylinder.length"))?,
            axis: axis_of(axis, "cylinder.axis")?,
            center: opt_vec3(center, Dim::LENGTH, &fl("cylinder.center"))?,
        },
        PrimitiveSpec::Capsule {
            radius,
            length,
            axis,
            center,
        } => Primitive::Capsule {
            radius: positive(radius, Dim::LENGTH, &fl("capsule.radius"))?,
            half_length: 0.5 * non_negative(length, Dim::LENGTH, &fl("capsule.length"))?,
            axis: axis_of(axis, "capsule.axis")?,
            center: opt_vec3(center, Dim::LENGTH, &fl("capsule.center"))?,
        },
        PrimitiveSpec::Point { position } => Primitive::Point {
            position: vec3(position, Dim::LENGTH, &fl("point.position"))?,
        },
    })
}

fn table(t: &Spanned<Vec<Vec<Quantity>>>, dim: Dim, field: &str) -> R<Profile> {
    let mut rows = Vec::new();
    for (k, row) in t.value.iter().enumerate() {
        if row.len() != 4 {
            return Err(SceneError::at(
                line(t),
                format!("{field}[{k}]"),
                "rows are [t, x, y, z]",
            ));
        }
        let err = |m: String| SceneError::at(line(t), format!("{field}[{k}]"), m);
        let time = row[0].value(Dim::TIME).map_err(err)?;
        let v = Vector3::new(
            row[1].value(dim).map_err(err)?,
            row[2].value(dim).map_err(err)?,
            row[3].value(dim).map_err(err)?,
        );
        if let Some((prev, _)) = rows.last() {
            if time <= *prev {
                return Err(SceneError::at(
                    line(t),
                    format!("{field}[{k}]"),
                    "times must increase strictly",
                ));
            }
        }
        rows.push((time, v));
    }
    if rows.is_empty() {
        return Err(SceneError::at(line(t), field, "needs at least one row"));
    }
    Ok(Profile::Table(rows))
}

fn profile(
    constant: &Option<Vector>,
    tab: &Option<Spanned<Vec<Vec<Quantity>>>>,
    dim: Dim,
    field: &str,
) -> R<Option<Profile>> {
    match (constant, tab) {
        (Some(c), None) => Ok(Some(Profile::Constant(vec3(c, dim, field)?))),
        (None, Some(t)) => Ok(Some(table(t, dim, &format!("{field}_table"))?)),
        (None, None) => Ok(None),
        (Some(c), Some(_)) => Err(SceneError::at(
            line(c),
            field,
            format!("give `{field}` or `{field}_table`, not both"),
        )),
    }
}

fn force(model: &Model, spec: &ForceSpec, i: usize) -> R<Force> {
    let f = |s: &str| format!("forces[{i}].{s}");
    let opt = |q: &Option<Q>, dim: Dim, name: &str| -> R<f64> {
        q.as_ref().map_or(Ok(0.0), |q| scalar(q, dim, &f(name)))
    };
    Ok(match spec {
        ForceSpec::Spring(s) => {
            let a = body_ref(model, &s.body_a, &f("spring.body_a"))?;
            let b = body_ref(model, &s.body_b, &f("spring.body_b"))?;
            let point_a = opt_vec3(&s.point_a, Dim::LENGTH, &f("spring.point_a"))?;
            let point_b = opt_vec3(&s.point_b, Dim::LENGTH, &f("spring.point_b"))?;
            let pose =
                |r: BodyRef| r.map_or(crate::mechanics::Pose::identity(), |i| model.bodies[i].pose);
            let initial = (pose(b).point(&point_b) - pose(a).point(&point_a)).norm();
            let damping = s.damping.as_ref().map_or(Ok(0.0), |q| {
                non_negative(q, Dim::DAMPING, &f("spring.damping"))
            })?;
            Force::Spring(PointSpring {
                a,
                point_a,
                b,
                point_b,
                stiffness: non_negative(&s.stiffness, Dim::STIFFNESS, &f("spring.stiffness"))?,
                damping,
                rest_length: s.rest_length.as_ref().map_or(Ok(initial), |q| {
                    non_negative(q, Dim::LENGTH, &f("spring.rest_length"))
                })?,
                preload: opt(&s.preload, Dim::FORCE, "spring.preload")?,
                ramp: ramp(&s.ramp, &f("spring.ramp"))?,
            })
        }
        ForceSpec::TorsionalSpring(s) => {
            let a = body_ref(model, &s.body_a, &f("torsional_spring.body_a"))?;
            let b = body_ref(model, &s.body_b, &f("torsional_spring.body_b"))?;
            let poses: Vec<_> = model.bodies.iter().map(|b| b.pose).collect();
            let mut spring = TorsionalSpring::new(
                a,
                b,
                unit_vec3(&s.axis, &f("torsional_spring.axis"))?,
                &poses,
                non_negative(&s.stiffness, Dim::TORQUE, &f("torsional_spring.stiffness"))?,
                s.damping.as_ref().map_or(Ok(0.0), |q| {
                    non_negative(q, Dim::ROTATIONAL_DAMPING, &f("torsional_spring.damping"))
                })?,
                opt(&s.preload, Dim::TORQUE, "torsional_spring.preload")?,
                opt(&s.rest_angle, Dim::NONE, "torsional_spring.rest_angle")?,
            );
            spring.ramp = ramp(&s.ramp, &f("torsional_spring.ramp"))?;
            Force::Torsional(spring)
        }
        ForceSpec::Load(l) => {
            let body = body_ref(model, &l.body, &f("load.body"))?.ok_or_else(|| {
                SceneError::at(
                    line(&l.body),
                    f("load.body"),
                    "a load acts on a body, not on the ground",
                )
            })?;
            let frame = match l.frame.as_ref().map(|s| s.value.as_str()) {
                None | Some("world") => Frame::World,
                Some("body") => Frame::Body,
                Some(o) => {
                    return Err(SceneError::at(
                        l.frame.as_ref().and_then(line),
                        f("load.frame"),
                        format!("unknown frame `{o}` (world or body)"),
                    ))
                }
            };
            let force = profile(&l.force, &l.force_table, Dim::FORCE, &f("load.force"))?;
            let torque = profile(&l.torque, &l.torque_table, Dim::TORQUE, &f("load.torque"))?;
            if force.is_none() && torque.is_none() {
                return Err(SceneError::at(
                    line(&l.body),
                    f("load"),
                    "needs a force or a torque",
                ));
            }
            Force::External(ExternalLoad {
                body,
                point: opt_vec3(&l.point, Dim::LENGTH, &f("load.point"))?,
                force,
                torque,
                frame,
            })
        }
    })
}

fn scalar_table(t: &Spanned<Vec<Vec<Quantity>>>, dim: Dim, field: &str) -> R<ScalarProfile> {
    let mut rows: Vec<(f64, f64)> = Vec::new();
    for (k, row) in t.value.iter().enumerate() {
        let err = |m: String| SceneError::at(line(t), format!("{field}[{k}]"), m);
        if row.len() != 2 {
            return Err(err("rows are [t, value]".into()));
        }
        let time = row[0].value(Dim::TIME).map_err(err)?;
        let v = row[1].value(dim).map_err(err)?;
        if rows.last().is_some_and(|(p, _)| time <= *p) {
            return Err(err("times must increase strictly".into()));
        }
        rows.push((time, v));
    }
    if rows.is_empty() {
        return Err(SceneError::at(line(t), field, "needs at least one row"));
    }
    Ok(ScalarProfile::Table(rows))
}

/// The two bodies of joint `i`: different, and at least one of them moving.
fn joint_bodies(model: &Model, spec: &JointSpec, i: usize) -> R<(BodyRef, BodyRef)> {
    let f = |s: &str| format!("joints[{i}].{s}");
    let a = body_ref(model, &spec.body_a, &f("body_a"))?;
    let b = body_ref(model, &spec.body_b, &f("body_b"))?;
    let moving = |r: BodyRef| r.is_some_and(|i| model.bodies[i].motion != Motion::Fixed);
    if a == b || !(moving(a) || moving(b)) {
        return Err(SceneError::at(
            line(&spec.body_b),
            f("body_b"),
            "a joint needs two different bodies, at least one of them moving",
        ));
    }
    Ok((a, b))
}

/// A joint of the scene: ideal (bilateral rows) or with clearance (contacts).
enum BuiltJoint {
    Ideal(Joint),
    Clearance(ClearanceJoint),
}

fn clearance_joint(model: &Model, spec: &JointSpec, i: usize) -> R<ClearanceJoint> {
    let f = |s: &str| format!("joints[{i}].{s}");
    let required = |q: &Option<Q>, name: &str, dim: Dim| -> R<f64> {
        let q = q.as_ref().ok_or_else(|| {
            SceneError::at(
                line(&spec.name),
                f(name),
                "is required for a revolute-clearance joint",
            )
        })?;
        positive(q, dim, &f(name))
    };
    let (a, b) = joint_bodies(model, spec, i)?;
    if spec.drive.is_some() || spec.limits.is_some() {
        return Err(SceneError::at(line(&spec.name), f("drive"), "a revolute-clearance joint has no drive or limits (drive the bodies with an ideal joint)"));
    }
    let journal_radius = required(&spec.journal_radius, "journal_radius", Dim::LENGTH)?;
    let rim = spec
        .rim_points
        .as_ref()
        .map_or(Ok(4), |q| count(q, &f("rim_points")))?;
    if rim < 3 {
        return Err(SceneError::at(
            spec.rim_points.as_ref().and_then(line),
            f("rim_points"),
            "needs at least 3 points per flange",
        ));
    }
    let e = restitution(&spec.e, &f("e"))?;
    let pose = |r: BodyRef| r.map_or(crate::mechanics::Pose::identity(), |i| model.bodies[i].pose);
    let (bore_center, bore_axis, journal_point, journal_axis) =
        if spec.anchor.is_some() || spec.axis.is_some() {
            let anchor = spec.anchor.as_ref().ok_or_else(|| {
                SceneError::at(
                    line(&spec.name),
                    f("anchor"),
                    "is required (bore centre, world, at assembly)",
                )
            })?;
            let anchor = vec3(anchor, Dim::LENGTH, &f("anchor"))?;
            let axis = spec.axis.as_ref().ok_or_else(|| {
                SceneError::at(
                    line(&spec.name),
                    f("axis"),
                    "is required for a revolute-clearance joint",
                )
            })?;
            let axis = unit_vec3(axis, &f("axis"))?;
            let (pa, pb) = (pose(a), pose(b));
            (
                pa.p.inverse_transform_vector(&(anchor - pa.x)),
                pa.p.inverse_transform_vector(&axis),
                pb.p.inverse_transform_vector(&(anchor - pb.x)),
                pb.p.inverse_transform_vector(&axis),
            )
        } else {
            fn need(v: &Option<Vector>, field: String, l: Option<u64>) -> R<&Vector> {
                v.as_ref().ok_or_else(|| {
                    SceneError::at(
                        l,
                        field,
                        "is required (or give anchor and axis in world coordinates)",
                    )
                })
            }
            let l = line(&spec.name);
            (
                vec3(
                    need(&spec.anchor_a, f("anchor_a"), l)?,
                    Dim::LENGTH,
                    &f("anchor_a"),
                )?,
                unit_vec3(need(&spec.axis_a, f("axis_a"), l)?, &f("axis_a"))?,
                vec3(
                    need(&spec.anchor_b, f("anchor_b"), l)?,
                    Dim::LENGTH,
                    &f("anchor_b"),
                )?,
                unit_vec3(need(&spec.axis_b, f("axis_b"), l)?, &f("axis_b"))?,
            )
        };
    Ok(ClearanceJoint {
        name: spec.name.value.clone(),
        bore_body: a,
        journal_body: b,
        bore_center,
        bore_axis,
        bore_length: required(&spec.bore_length, "bore_length", Dim::LENGTH)?,
        journal_point,
        journal_axis,
        journal_radius,
        clearance: required(&spec.clearance, "clearance", Dim::LENGTH)?,
        axial_play: spec
            .axial_play
            .as_ref()
            .map_or(Ok(1e-4), |q| positive(q, Dim::LENGTH, &f("axial_play")))?,
        flange_radius: spec
            .flange_radius
            .as_ref()
            .map_or(Ok(1.5 * journal_radius), |q| {
                positive(q, Dim::LENGTH, &f("flange_radius"))
            })?,
        rim_points: rim,
        mu: spec
            .mu
            .as_ref()
            .map_or(Ok(0.0), |q| non_negative(q, Dim::NONE, &f("mu")))?,
        e,
    })
}

fn joint(model: &Model, spec: &JointSpec, i: usize) -> R<BuiltJoint> {
    let f = |s: &str| format!("joints[{i}].{s}");
    if spec.kind.value == "revolute-clearance" {
        return clearance_joint(model, spec, i).map(BuiltJoint::Clearance);
    }
    let kind = match spec.kind.value.as_str() {
        "revolute" => JointKind::Revolute,
        "prismatic" => JointKind::Prismatic,
        "spherical" => JointKind::Spherical,
        "fixed" => JointKind::Fixed,
        other => {
            return Err(SceneError::at(
                line(&spec.kind),
                f("type"),
                format!("unknown joint type `{other}` (revolute, revolute-clearance, prismatic, spherical, fixed)"),
            ))
        }
    };
    let (a, b) = joint_bodies(model, spec, i)?;
    let drive = match &spec.drive {
        None => None,
        Some(d) => {
            if kind != JointKind::Revolute && kind != JointKind::Prismatic {
                return Err(SceneError::at(
                    line(d),
                    f("drive"),
                    "only revolute and prismatic joints can be driven",
                ));
            }
            let rot = kind == JointKind::Revolute;
            let (vel_dim, pos_dim, eff_dim) = if rot {
                (Dim::ANGULAR_VELOCITY, Dim::NONE, Dim::TORQUE)
            } else {
                (Dim::VELOCITY, Dim::LENGTH, Dim::FORCE)
            };
            let s = &d.value;
            let given = [
                s.velocity.is_some(),
                s.position_table.is_some(),
                s.effort.is_some(),
                s.effort_table.is_some(),
            ];
            if given.iter().filter(|&&g| g).count() != 1 {
                return Err(SceneError::at(
                    line(d),
                    f("drive"),
                    "give exactly one of `velocity`, `position_table`, `effort`, `effort_table`",
                ));
            }
            Some(if let Some(v) = &s.velocity {
                Drive::Position(ScalarProfile::Rate {
                    start: 0.0,
                    rate: scalar(v, vel_dim, &f("drive.velocity"))?,
                })
            } else if let Some(t) = &s.position_table {
                Drive::Position(scalar_table(t, pos_dim, &f("drive.position_table"))?)
            } else if let Some(e) = &s.effort {
                Drive::Effort(ScalarProfile::Rate {
                    start: scalar(e, eff_dim, &f("drive.effort"))?,
                    rate: 0.0,
                })
            } else {
                Drive::Effort(scalar_table(
                    s.effort_table.as_ref().expect("one drive given"),
                    eff_dim,
                    &f("drive.effort_table"),
                )?)
            })
        }
    };
    let limits = match &spec.limits {
        None => None,
        Some(l) => {
            if kind != JointKind::Revolute && kind != JointKind::Prismatic {
                return Err(SceneError::at(
                    line(l),
                    f("limits"),
                    "only revolute and prismatic joints have limits",
                ));
            }
            let dim = if kind == JointKind::Revolute {
                Dim::NONE
            } else {
                Dim::LENGTH
            };
            let lower = scalar(&l.value.lower, dim, &f("limits.lower"))?;
            let upper = scalar(&l.value.upper, dim, &f("limits.upper"))?;
            if lower > 0.0 || upper < 0.0 || lower >= upper {
                return Err(SceneError::at(
                    line(l),
                    f("limits"),
                    format!("need lower ≤ 0 ≤ upper and lower < upper (the assembled configuration is 0), got [{lower}, {upper}]"),
                ));
            }
            let e = restitution(&l.value.e, &f("limits.e"))?;
            Some(JointLimits { lower, upper, e })
        }
    };
    let poses: Vec<_> = model.bodies.iter().map(|b| b.pose).collect();
    let world = spec.anchor.is_some() || spec.axis.is_some();
    let local = [&spec.anchor_a, &spec.anchor_b, &spec.axis_a, &spec.axis_b]
        .iter()
        .any(|x| x.is_some());
    if world && local {
        return Err(SceneError::at(line(&spec.name), f("anchor"), "give `anchor`/`axis` (world) or `anchor_a`, `anchor_b`, `axis_a`, `axis_b` (body frames), not both"));
    }
    let needs_axis = kind != JointKind::Spherical;
    let joint = if world || !local {
        let anchor = spec.anchor.as_ref().ok_or_else(|| {
            SceneError::at(
                line(&spec.name),
                f("anchor"),
                "is required (world point at the assembled configuration)",
            )
        })?;
        let axis = match &spec.axis {
            Some(x) => unit_vec3(x, &f("axis"))?,
            None if needs_axis => {
                return Err(SceneError::at(
                    line(&spec.name),
                    f("axis"),
                    format!("is required for a {} joint", kind.name()),
                ))
            }
            None => Vector3::z(),
        };
        Joint::from_world(
            spec.name.value.clone(),
            kind,
            a,
            b,
            vec3(anchor, Dim::LENGTH, &f("anchor"))?,
            axis,
            &poses,
            drive,
        )
    } else {
        let axis_of = |x: &Option<Vector>, n: &str| -> R<Vector3<f64>> {
            match x {
                Some(x) => unit_vec3(x, &f(n)),
                None if needs_axis => Err(SceneError::at(
                    line(&spec.name),
                    f(n),
                    format!("is required for a {} joint", kind.name()),
                )),
                None => Ok(Vector3::z()),
            }
        };
        Joint::new(
            spec.name.value.clone(),
            kind,
            a,
            b,
            opt_vec3(&spec.anchor_a, Dim::LENGTH, &f("anchor_a"))?,
            opt_vec3(&spec.anchor_b, Dim::LENGTH, &f("anchor_b"))?,
            axis_of(&spec.axis_a, "axis_a")?,
            axis_of(&spec.axis_b, "axis_b")?,
            &poses,
            drive,
        )
    };
    Ok(BuiltJoint::Ideal(match limits {
        Some(l) => joint.with_limits(l),
        None => joint,
    }))
}

pub(super) fn count(q: &Q, field: &str) -> R<usize> {
    let v = positive(q, Dim::NONE, field)?;
    if v.fract() != 0.0 {
        return Err(SceneError::at(
            line(q),
            field,
            format!("must be a whole number, got {v}"),
        ));
    }
    Ok(v as usize)
}

/// Applies an `integrator` block (or a study's `fidelity` block, named by `prefix`) on top
/// of `p`.
pub fn apply_integrator(
    spec: &IntegratorSpec,
    p: &mut IntegrationParameters,
    prefix: &str,
) -> R<()> {
    if let Some(name) = &spec.preset {
        let preset = Preset::parse(&name.value).ok_or_else(|| {
            SceneError::at(
                line(name),
                format!("{prefix}.preset"),
                format!(
                    "unknown preset `{}` (available: fast, balanced, accurate)",
                    name.value
                ),
            )
        })?;
        preset.apply(p);
    }
    if let Some(h) = &spec.h {
        p.h = positive(h, Dim::TIME, &format!("{prefix}.h"))?;
    }
    if let Some(t) = &spec.theta {
        p.theta = scalar(t, Dim::NONE, &format!("{prefix}.theta"))?;
    }
    if let Some(g) = &spec.gamma {
        p.gamma = scalar(g, Dim::NONE, &format!("{prefix}.gamma"))?;
    }
    if let Some(s) = &spec.scheme {
        p.scheme = Scheme::parse(&s.value).ok_or_else(|| {
            SceneError::at(
                line(s),
                format!("{prefix}.scheme"),
                format!("unknown scheme `{}` (available: moreau-jean, combined-projection, direct-projection)", s.value),
            )
        })?;
    }
    if let Some(m) = &spec.activation_margin {
        p.activation_margin = non_negative(m, Dim::LENGTH, &format!("{prefix}.activation_margin"))?;
    }
    if let Some(s) = &spec.solver {
        if let Some(t) = &s.tolerance {
            p.solver.tolerance = positive(t, Dim::NONE, &format!("{prefix}.solver.tolerance"))?;
        }
        if let Some(m) = &s.max_iterations {
            p.solver.max_sweeps = count(m, &format!("{prefix}.solver.max_iterations"))?;
        }
    }
    if let Some(l) = spec.locate_impacts {
        p.locate_impacts = l;
    }
    if let Some(s) = &spec.projection {
        if let Some(t) = &s.tolerance {
            p.projection_tolerance =
                positive(t, Dim::NONE, &format!("{prefix}.projection.tolerance"))?;
        }
        if let Some(m) = &s.max_iterations {
            p.projection_max_iterations = count(m, &format!("{prefix}.projection.max_iterations"))?;
        }
    }
    if let Some(s) = &spec.newton {
        if let Some(t) = &s.tolerance {
            p.newton_tolerance = positive(t, Dim::NONE, &format!("{prefix}.newton.tolerance"))?;
        }
        if let Some(m) = &s.max_iterations {
            p.newton_max_iterations = count(m, &format!("{prefix}.newton.max_iterations"))?;
        }
    }
    let field_line = |name: &str| -> Option<u64> {
        match name {
            "theta" => spec.theta.as_ref().and_then(line),
            "gamma" => spec.gamma.as_ref().and_then(line),
            _ => None,
        }
    };
    p.validate()
        .map_err(|(f, m)| SceneError::at(field_line(f), format!("{prefix}.{f}"), m))
}

/// The contact pairs and clearance joints that keep their friction while settling: names
/// of the scene's contacts or joints.
fn settle_friction(model: &Model, names: &Spanned<Vec<Name>>) -> R<Vec<String>> {
    let known = |n: &str| {
        model.contacts.iter().any(|c| c.name == n)
            || model.clearance_joints.iter().any(|j| j.name == n)
            || model.joints.iter().any(|j| j.name == n)
    };
    names
        .value
        .iter()
        .enumerate()
        .map(|(i, n)| {
            if known(&n.value) {
                Ok(n.value.clone())
            } else {
                Err(SceneError::at(
                    line(n),
                    format!("settle.friction[{i}]"),
                    format!("unknown contact or joint `{}`", n.value),
                ))
            }
        })
        .collect()
}

pub(super) fn build(spec: &SceneSpec) -> R<Scene> {
    if let Some(k) = spec.kind.as_ref().filter(|k| k.value != "mechanism") {
        return Err(SceneError::at(
            line(k),
            "type",
            format!("unknown scene type `{}` (mechanism, function)", k.value),
        ));
    }
    let mut model = Model {
        gravity: match &spec.gravity {
            Some(g) => vec3(g, Dim::ACCELERATION, "gravity")?,
            None => Vector3::new(0.0, 0.0, -9.81),
        },
        ..Default::default()
    };
    if spec.bodies.is_empty() {
        return Err(SceneError::at(
            None,
            "bodies",
            "a scene needs at least one body",
        ));
    }
    for (i, b) in spec.bodies.iter().enumerate() {
        if model.body_index(&b.name.value).is_some() {
            return Err(SceneError::at(
                line(&b.name),
                format!("bodies[{i}].name"),
                format!("duplicate body name `{}`", b.name.value),
            ));
        }
        model.bodies.push(body(b, i)?);
    }
    for (i, c) in spec.contacts.iter().enumerate() {
        let f = |s: &str| format!("contacts[{i}].{s}");
        let b1 = body_ref(&model, &c.body, &f("body"))?;
        let b2 = match &c.against {
            Some(n) => body_ref(&model, n, &f("against"))?,
            None => None,
        };
        let mu =
            c.mu.as_ref()
                .map_or(Ok(0.0), |q| non_negative(q, Dim::NONE, &f("mu")))?;
        let e = restitution(&c.e, &f("e"))?;
        let name = c.name.clone().unwrap_or_else(|| format!("contact{i}"));
        let pair = ContactPair::new(
            name,
            b1,
            primitive(&c.shape, &f("shape"))?,
            b2,
            primitive(&c.against_shape, &f("against_shape"))?,
            mu,
            e,
        )
        .map_err(|m| SceneError::at(line(&c.shape), f("shape"), m))?;
        model.contacts.push(pair);
    }
    for (i, fs) in spec.forces.iter().enumerate() {
        let f = force(&model, fs, i)?;
        model.forces.push(f);
    }
    for (i, j) in spec.joints.iter().enumerate() {
        if model.joints.iter().any(|k| k.name == j.name.value)
            || model
                .clearance_joints
                .iter()
                .any(|k| k.name == j.name.value)
        {
            return Err(SceneError::at(
                line(&j.name),
                format!("joints[{i}].name"),
                format!("duplicate joint name `{}`", j.name.value),
            ));
        }
        match joint(&model, j, i)? {
            BuiltJoint::Ideal(joint) => model.joints.push(joint),
            BuiltJoint::Clearance(joint) => model.clearance_joints.push(joint),
        }
    }
    let duration = positive(&spec.duration, Dim::TIME, "duration")?;
    let mut params = IntegrationParameters::default();
    apply_integrator(&spec.integrator, &mut params, "integrator")?;
    if let Some(s) = &spec.settle {
        model.settle = Some(Settle {
            until: positive(&s.value.until, Dim::TIME, "settle.until")?,
            damping: s.value.damping.as_ref().map_or(Ok(0.0), |q| {
                non_negative(q, Dim::ANGULAR_VELOCITY, "settle.damping")
            })?,
            friction: match &s.value.friction {
                None => None,
                Some(names) => Some(settle_friction(&model, names)?),
            },
            step_ratio: match &s.value.h {
                None => None,
                Some(h) => Some(positive(h, Dim::TIME, "settle.h")? / params.h),
            },
            tolerance_ratio: match &s.value.tolerance {
                None => None,
                Some(t) => {
                    Some(positive(t, Dim::NONE, "settle.tolerance")? / params.solver.tolerance)
                }
            },
        });
    }
    if let Some(r) = &spec.refine {
        model.refine = Some(Refine {
            trigger: super::probes::contact(&model, &r.value.after, "refine.after")?,
            duration: positive(&r.value.duration, Dim::TIME, "refine.for")?,
            step_ratio: positive(&r.value.h, Dim::TIME, "refine.h")? / params.h,
            extrapolate: r.value.extrapolate,
        });
    }
    let record_every = spec
        .record
        .every
        .as_ref()
        .map_or(Ok(1), |q| count(q, "record.every"))?;
    Ok(Scene {
        name: spec.name.clone().unwrap_or_else(|| "scene".into()),
        probes: super::probes::probes(&model, &spec.probes)?,
        params,
        model,
        duration,
        record_every,
    })
}
