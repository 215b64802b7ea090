//! Contact pairs: the shapes (sphere, plane, box, cylinder, cone, capsule, point, profile,
//! convex part, mesh) on two bodies, with their friction and restitution.

use super::compliance::{compliant_law, is_compliant};
use super::error::{line, SceneError};
use super::fields::{
    body_ref, non_negative, opt_vec3, orientation, positive, restitution, scalar, unit_vec3,
    values, vec3, R,
};
use super::schema::{ContactSpec, Name, PieceSpec, PrimitiveSpec, ProfileSpec, Vector, Q};
use crate::input::units::{Dim, Quantity};
use crate::mechanics::contact::compliant::{CompliantContact, CompliantSource};
use crate::mechanics::contact::convex::ConvexPart;
use crate::mechanics::contact::mesh::{self, MeshPart};
use crate::mechanics::contact::profile::{Outline, Piece as ProfilePiece, Solid};
use crate::mechanics::{ContactPair, Model, Primitive};
use nalgebra::{UnitQuaternion, Vector2, Vector3};
use serde_saphyr::Spanned;

/// A contact entry as built: a rigid pair, or a pair under a compliant law.
pub(super) enum BuiltContact {
    Rigid(ContactPair),
    Compliant(CompliantContact),
}

/// Contact pair `i`.
pub(super) fn contact(model: &Model, c: &ContactSpec, i: usize, file: &str) -> R<BuiltContact> {
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
    let pair = ContactPair::new(
        name,
        b1,
        primitive(&c.shape, &f("shape"), file)?,
        b2,
        primitive(&c.against_shape, &f("against_shape"), file)?,
        mu,
        e,
    )
    .map_err(|m| SceneError::at(line(&c.shape), f("shape"), m))?;
    if !is_compliant(&c.law, &c.compliance, line(&c.body), &f)? {
        return Ok(BuiltContact::Rigid(pair));
    }
    let law = compliant_law(
        &c.compliance,
        hertz_radius(&pair),
        (mu, e),
        line(&c.body),
        &f,
    )?;
    Ok(BuiltContact::Compliant(CompliantContact {
        source: CompliantSource::Pair(pair),
        law,
    }))
}

/// The effective radius R of Hertz's law for a pair: a sphere's against a plane,
/// R₁R₂/(R₁ + R₂) for two spheres.
fn hertz_radius(pair: &ContactPair) -> Result<f64, &'static str> {
    match (&pair.shape1, &pair.shape2) {
        (Primitive::Sphere { radius, .. }, Primitive::Plane { .. }) => Ok(*radius),
        (Primitive::Sphere { radius: a, .. }, Primitive::Sphere { radius: b, .. }) => {
            Ok(a * b / (a + b))
        }
        _ => Err(
            "Hertz's stiffness follows from the materials for a sphere against a plane or a sphere",
        ),
    }
}

fn primitive(p: &Spanned<PrimitiveSpec>, field: &str, file: &str) -> R<Primitive> {
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
        } => Primitive::Box {
            half_extents: positive_size(size, &fl("box.size"))? * 0.5,
            center: opt_vec3(center, Dim::LENGTH, &fl("box.center"))?,
            rotation: o.as_ref().map_or(Ok(UnitQuaternion::identity()), |o| {
                orientation(o, &fl("box.orientation"))
            })?,
        },
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
        PrimitiveSpec::Cone {
            radius,
            length,
            axis,
            center,
        } => Primitive::Cone {
            radius: positive(radius, Dim::LENGTH, &fl("cone.radius"))?,
            half_length: 0.5 * positive(length, Dim::LENGTH, &fl("cone.length"))?,
            axis: axis_of(axis, "cone.axis")?,
            center: opt_vec3(center, Dim::LENGTH, &fl("cone.center"))?,
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
        PrimitiveSpec::Convex {
            vertices,
            file: mesh,
            scale,
            rounding,
        } => convex(p, vertices, mesh, scale, rounding, file, field)?,
        PrimitiveSpec::Mesh { file: name, scale } => {
            let (vertices, triangles) = read_mesh(name, &Some(scale.clone()), file, &fl("mesh"))?;
            Primitive::Mesh(Box::new(
                MeshPart::new(vertices, triangles)
                    .map_err(|m| SceneError::at(line(name), fl("mesh.file"), m))?,
            ))
        }
        PrimitiveSpec::Profile(spec) => {
            Primitive::Profile(Box::new(profile(spec, line(p), &fl("profile"))?))
        }
    })
}

/// A convex part: the hull of its `vertices`, or of the vertices of its mesh `file` (which
/// must be a closed convex surface), with its edges and corners rounded by `rounding`.
fn convex(
    p: &Spanned<PrimitiveSpec>,
    vertices: &Option<Spanned<Vec<Vec<Quantity>>>>,
    mesh: &Option<Name>,
    scale: &Option<Q>,
    rounding: &Option<Q>,
    file: &str,
    field: &str,
) -> R<Primitive> {
    let fl = |s: &str| format!("{field}.{s}");
    let points = match (vertices, mesh) {
        (Some(t), None) => t
            .value
            .iter()
            .enumerate()
            .map(|(r, row)| {
                if row.len() != 3 {
                    return Err(SceneError::at(
                        line(t),
                        fl(&format!("convex.vertices[{r}]")),
                        format!("a vertex needs 3 coordinates, got {}", row.len()),
                    ));
                }
                let c = |k: usize| {
                    row[k].value(Dim::LENGTH).map_err(|m| {
                        SceneError::at(line(t), fl(&format!("convex.vertices[{r}]")), m)
                    })
                };
                Ok(Vector3::new(c(0)?, c(1)?, c(2)?))
            })
            .collect::<R<Vec<_>>>()?,
        (None, Some(name)) => {
            let (vertices, triangles) = read_mesh(name, scale, file, &fl("convex"))?;
            mesh::check(&vertices, &triangles)
                .and_then(|()| mesh::check_convex(&vertices, &triangles))
                .map_err(|m| SceneError::at(line(name), fl("convex.file"), m))?;
            vertices
        }
        _ => {
            return Err(SceneError::at(
                line(p),
                fl("convex"),
                "give `vertices` or a mesh `file`, one of the two",
            ))
        }
    };
    let at = vertices
        .as_ref()
        .and_then(line)
        .or(mesh.as_ref().and_then(line));
    let rounding = rounding.as_ref().map_or(Ok(0.0), |q| {
        non_negative(q, Dim::LENGTH, &fl("convex.rounding"))
    })?;
    Ok(Primitive::Convex(Box::new(
        ConvexPart::new(&points, true)
            .map_err(|m| SceneError::at(at, fl("convex"), m))?
            .rounded(rounding),
    )))
}

/// The mesh in file `name` (relative to the scene file `scene`), scaled to metres.
fn read_mesh(
    name: &Name,
    scale: &Option<Q>,
    scene: &str,
    field: &str,
) -> R<super::mesh_file::Triangles> {
    let Some(scale) = scale else {
        return Err(SceneError::at(
            line(name),
            format!("{field}.scale"),
            "needed with a mesh file: the length of one file unit, e.g. `scale: 1 mm`",
        ));
    };
    let scale = positive(scale, Dim::LENGTH, &format!("{field}.scale"))?;
    let path = std::path::Path::new(scene)
        .parent()
        .unwrap_or(std::path::Path::new(""))
        .join(&name.value);
    super::mesh_file::read(&path, scale)
        .map_err(|m| SceneError::at(line(name), format!("{field}.file"), m))
}

/// A profile's path: its pieces and its first point (a lone circle's is on its rim).
fn path(p: &ProfileSpec, at: Option<u64>, field: &str) -> R<(Vec<ProfilePiece>, Vector2<f64>)> {
    let fl = |s: &str| format!("{field}.{s}");
    let circle = |i: usize| matches!(p.path.value[i].value, PieceSpec::Circle { .. });
    let start = match (&p.start, p.path.value.len()) {
        (None, 1) if circle(0) => None,
        (Some(s), _) if !(0..p.path.value.len()).any(circle) => Some(point2(s, &fl("start"))?),
        (Some(s), _) => {
            return Err(SceneError::at(
                line(s),
                fl("start"),
                "a path that is one `circle` has no `start`",
            ))
        }
        (None, _) => {
            return Err(SceneError::at(
                at,
                fl("start"),
                "needed: the path's first point (only a path that is one `circle` has none)",
            ))
        }
    };
    if let Some(i) = (0..p.path.value.len())
        .find(|&i| circle(i))
        .filter(|_| p.path.value.len() > 1)
    {
        return Err(SceneError::at(
            line(&p.path.value[i]),
            fl(&format!("path[{i}]")),
            "a `circle` is a whole path: it cannot be joined to other pieces",
        ));
    }
    let mut pieces = Vec::with_capacity(p.path.value.len());
    let mut start_point = start.unwrap_or_default();
    for (i, piece) in p.path.value.iter().enumerate() {
        let fi = |s: &str| fl(&format!("path[{i}].{s}"));
        pieces.push(match &piece.value {
            PieceSpec::Circle { center, radius } => {
                let center = point2(center, &fi("circle.center"))?;
                start_point =
                    center + Vector2::x() * positive(radius, Dim::LENGTH, &fi("circle.radius"))?;
                ProfilePiece::Arc {
                    to: start_point,
                    center,
                    ccw: true,
                }
            }
            PieceSpec::Line(to) => ProfilePiece::Line {
                to: point2(to, &fi("line"))?,
            },
            PieceSpec::Arc {
                to,
                center,
                direction,
            } => ProfilePiece::Arc {
                to: point2(to, &fi("arc.to"))?,
                center: point2(center, &fi("arc.center"))?,
                ccw: match direction.as_ref().map(|d| d.value.as_str()) {
                    None | Some("ccw") => true,
                    Some("cw") => false,
                    Some(other) => {
                        return Err(SceneError::at(
                            direction.as_ref().and_then(line),
                            fi("arc.direction"),
                            format!("unknown direction `{other}` (expected ccw or cw)"),
                        ))
                    }
                },
            },
        });
    }
    Ok((pieces, start_point))
}

/// A box's size, each side positive.
fn positive_size(size: &Vector, field: &str) -> R<Vector3<f64>> {
    let s = vec3(size, Dim::LENGTH, field)?;
    if s.iter().any(|&x| x <= 0.0) {
        return Err(SceneError::at(line(size), field, "must be positive"));
    }
    Ok(s)
}

/// A point of a profile's plane.
fn point2(v: &Vector, field: &str) -> R<Vector2<f64>> {
    let x = values(v, Dim::LENGTH, field, 2)?;
    Ok(Vector2::new(x[0], x[1]))
}

fn profile(p: &ProfileSpec, at: Option<u64>, field: &str) -> R<Outline> {
    let fl = |s: &str| format!("{field}.{s}");
    let axes = match p.plane.as_ref().map(|n| n.value.as_str()) {
        None | Some("xy") => [Vector3::x(), Vector3::y(), Vector3::z()],
        Some("yz") => [Vector3::y(), Vector3::z(), Vector3::x()],
        Some("xz") => [Vector3::x(), Vector3::z(), -Vector3::y()],
        Some(other) => {
            return Err(SceneError::at(
                p.plane.as_ref().and_then(line),
                fl("plane"),
                format!("unknown plane `{other}` (expected xy, yz or xz)"),
            ))
        }
    };
    let offset = p
        .offset
        .as_ref()
        .map_or(Ok(0.0), |q| scalar(q, Dim::LENGTH, &fl("offset")))?;
    let thickness = positive(&p.thickness, Dim::LENGTH, &fl("thickness"))?;
    let (pieces, start_point) = path(p, at, field)?;
    let solid = match p.solid.as_ref().map(|n| n.value.as_str()) {
        None | Some("inside") => Solid::Inside,
        Some("outside") => Solid::Outside,
        Some("left") => Solid::Left,
        Some("right") => Solid::Right,
        Some(other) => {
            return Err(SceneError::at(
                p.solid.as_ref().and_then(line),
                fl("solid"),
                format!("unknown side `{other}` (expected inside, outside, left or right)"),
            ))
        }
    };
    Outline::new(
        axes[2] * offset,
        axes,
        thickness,
        start_point,
        &pieces,
        solid,
    )
    .map_err(|(piece, message)| match piece {
        Some(i) => SceneError::at(line(&p.path.value[i]), fl(&format!("path[{i}]")), message),
        None => SceneError::at(at, field.to_string(), message),
    })
}
