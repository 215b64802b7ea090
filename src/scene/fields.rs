//! The field readers every part of the scene shares: a quantity in its dimension, checked
//! (finite, positive, in [0, 1], whole), vectors and unit vectors, orientations and body
//! names. Each error names the field and its line.

use super::error::{line, SceneError};
use super::schema::{Name, OrientationSpec, Vector, Q};
use crate::input::units::{Dim, Quantity};
use crate::mechanics::{BodyRef, Model};
use nalgebra::{Quaternion, Unit, UnitQuaternion, Vector3};
use serde_saphyr::Spanned;

pub(super) type R<T> = Result<T, SceneError>;

/// The value of a field the scene must give; without it, an error at `at` saying it is
/// required, and `why`.
pub(super) fn given<'a, T>(v: &'a Option<T>, at: Option<u64>, field: &str, why: &str) -> R<&'a T> {
    v.as_ref()
        .ok_or_else(|| SceneError::at(at, field, format!("is required {why}")))
}

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

pub(super) fn positive(q: &Q, dim: Dim, field: &str) -> R<f64> {
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

pub(super) fn non_negative(q: &Q, dim: Dim, field: &str) -> R<f64> {
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

pub(super) fn values(v: &Vector, dim: Dim, field: &str, len: usize) -> R<Vec<f64>> {
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
pub(super) fn restitution(q: &Option<Q>, field: &str) -> R<f64> {
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

pub(super) fn vec3(v: &Vector, dim: Dim, field: &str) -> R<Vector3<f64>> {
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

pub(super) fn orientation(o: &Spanned<OrientationSpec>, field: &str) -> R<UnitQuaternion<f64>> {
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
