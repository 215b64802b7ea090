//! Contact pairs: the primitive shapes (sphere, plane, box, cylinder, capsule, point) on
//! two bodies, with their friction and restitution.

use super::error::{line, SceneError};
use super::fields::{
    body_ref, non_negative, opt_vec3, orientation, positive, restitution, unit_vec3, vec3, R,
};
use super::schema::{ContactSpec, PrimitiveSpec, Vector};
use super::units::Dim;
use crate::mechanics::{ContactPair, Model, Primitive};
use nalgebra::{UnitQuaternion, Vector3};
use serde_saphyr::Spanned;

/// Contact pair `i`.
pub(super) fn contact(model: &Model, c: &ContactSpec, i: usize) -> R<ContactPair> {
    let f = |s: &str| format!("contacts[{i}].{s}");
    let b1 = body_ref(model, &c.body, &f("body"))?;
    let b2 = match &c.against {
        Some(n) => body_ref(model, n, &f("against"))?,
        None => None,
    };
    let mu =
        c.mu.as_ref()
            .map_or(Ok(0.0), |q| non_negative(q, Dim::NONE, &f("mu")))?;
    let e = restitution(&c.e, &f("e"))?;
    if c.name
        .as_ref()
        .is_some_and(|n| n.is_empty() || n.contains('.'))
    {
        return Err(SceneError::at(
            line(&c.body),
            f("name"),
            "must be non-empty and without `.` (names are parts of parameter paths)",
        ));
    }
    let name = c.name.clone().unwrap_or_else(|| format!("contact{i}"));
    ContactPair::new(
        name,
        b1,
        primitive(&c.shape, &f("shape"))?,
        b2,
        primitive(&c.against_shape, &f("against_shape"))?,
        mu,
        e,
    )
    .map_err(|m| SceneError::at(line(&c.shape), f("shape"), m))
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
