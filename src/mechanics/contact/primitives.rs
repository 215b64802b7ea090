//! Analytic closest points between primitives. Each primitive is given in its body's
//! frame; `closest` returns the gap, the inertial normal (from body 2 towards body 1) and
//! the two contact points for one candidate index.

use super::convex::{ConvexPart, Surface};
use super::mesh::MeshPart;
use super::profile::{Outline, Pin, OUT_OF_REACH};
use super::revolution::Revolution;
use crate::math::any_orthogonal;
use crate::mechanics::body::Pose;
use nalgebra::{UnitQuaternion, Vector3};

#[derive(Clone, Debug, PartialEq)]
pub enum Primitive {
    Sphere {
        center: Vector3<f64>,
        radius: f64,
    },
    /// Boundary of a half-space: the solid lies on the side opposite to `normal`.
    Plane {
        point: Vector3<f64>,
        normal: Vector3<f64>,
    },
    /// Its 8 corners are the contact candidates.
    Box {
        center: Vector3<f64>,
        rotation: UnitQuaternion<f64>,
        half_extents: Vector3<f64>,
    },
    /// Solid cylinder; candidates are the deepest point of each end circle.
    Cylinder {
        center: Vector3<f64>,
        axis: Vector3<f64>,
        radius: f64,
        half_length: f64,
    },
    /// Solid cone, its base at −`half_length` along `axis` from `center` and its apex at
    /// +`half_length`; against a plane, the apex and the deepest point of the base circle.
    Cone {
        center: Vector3<f64>,
        axis: Vector3<f64>,
        radius: f64,
        half_length: f64,
    },
    /// Segment swept sphere; candidates are the two end spheres.
    Capsule {
        center: Vector3<f64>,
        axis: Vector3<f64>,
        radius: f64,
        half_length: f64,
    },
    Point {
        position: Vector3<f64>,
    },
    /// A planar profile of segments and arcs, extruded (`profile.rs`); pins (points,
    /// spheres, cylinders) meet it.
    Profile(Box<Outline>),
    /// A convex polyhedron (`convex.rs`).
    Convex(Box<ConvexPart>),
    /// A triangle mesh, for fixed parts (`mesh.rs`).
    Mesh(Box<MeshPart>),
}

impl Primitive {
    pub fn kind(&self) -> &'static str {
        match self {
            Primitive::Sphere { .. } => "sphere",
            Primitive::Plane { .. } => "plane",
            Primitive::Box { .. } => "box",
            Primitive::Cylinder { .. } => "cylinder",
            Primitive::Cone { .. } => "cone",
            Primitive::Capsule { .. } => "capsule",
            Primitive::Point { .. } => "point",
            Primitive::Profile(_) => "profile",
            Primitive::Convex(_) => "convex",
            Primitive::Mesh(_) => "mesh",
        }
    }

    /// A box as the convex part with its 8 corners (any other shape as it is).
    pub(crate) fn into_convex(self) -> Primitive {
        match self {
            Primitive::Box {
                center,
                rotation,
                half_extents: h,
            } => {
                let corners: Vec<Vector3<f64>> = (0..8)
                    .map(|k| {
                        let s = |bit: usize| if k & bit != 0 { 1.0 } else { -1.0 };
                        center + rotation * Vector3::new(s(1) * h.x, s(2) * h.y, s(4) * h.z)
                    })
                    .collect();
                Primitive::Convex(Box::new(
                    ConvexPart::new(&corners, true).expect("a box with positive sides is convex"),
                ))
            }
            other => other,
        }
    }

    /// The contact planes of this shape as a pin against a profile: a cylinder touches
    /// with its sections in the profile's two faces, a point or sphere with its centre's.
    pub(crate) fn pin_faces(&self) -> usize {
        match self {
            Primitive::Cylinder { .. } => 2,
            _ => 1,
        }
    }

    /// Candidate points of this shape against a plane or sphere.
    pub(crate) fn candidate_count(&self) -> usize {
        match self {
            Primitive::Box { .. } => 8,
            Primitive::Convex(c) => c.vertices.len(),
            Primitive::Cylinder { .. } | Primitive::Cone { .. } | Primitive::Capsule { .. } => 2,
            _ => 1,
        }
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactGeometry {
    /// Signed distance, > 0 when separated.
    pub gap: f64,
    /// Unit normal (inertial) from body 2 towards body 1.
    pub normal: Vector3<f64>,
    /// Point on body 1's surface (inertial).
    pub point1: Vector3<f64>,
    /// Point on body 2's surface (inertial).
    pub point2: Vector3<f64>,
}

fn point_plane(
    x: Vector3<f64>,
    plane_point: Vector3<f64>,
    n: Vector3<f64>,
    radius: f64,
) -> ContactGeometry {
    let dist = n.dot(&(x - plane_point));
    ContactGeometry {
        gap: dist - radius,
        normal: n,
        point1: x - n * radius,
        point2: x - n * dist,
    }
}

/// A sphere (or point, `radius` 0) at inertial centre `x` against a solid box: the
/// closest point of the box is the centre clamped into it, so the contact has a finite face
/// and rounded edges (a latch nose slides off the edge of a tooth). Inside the box, the
/// nearest face gives the normal.
fn sphere_box(
    x: Vector3<f64>,
    radius: f64,
    pose: &Pose,
    center: &Vector3<f64>,
    rotation: &UnitQuaternion<f64>,
    h: &Vector3<f64>,
) -> ContactGeometry {
    let to_world = pose.p * rotation;
    let local = to_world.inverse_transform_vector(&(x - pose.point(center)));
    let clamped = local.zip_map(h, |v, e| v.clamp(-e, e));
    let d = local - clamped;
    let dist = d.norm();
    let (gap, n_local, surface) = if dist > 0.0 {
        (dist - radius, d / dist, clamped)
    } else {
        // inside: leave through the face of least depth
        let depth = h - local.abs();
        let i = depth.imin();
        let sign = if local[i] >= 0.0 { 1.0 } else { -1.0 };
        let mut n = Vector3::zeros();
        n[i] = sign;
        let mut s = local;
        s[i] = sign * h[i];
        (-depth[i] - radius, n, s)
    };
    let normal = to_world * n_local;
    ContactGeometry {
        gap,
        normal,
        point1: x - normal * radius,
        point2: pose.point(&(center + rotation * surface)),
    }
}

/// The surface of a convex part or mesh (on a body at `pose`) nearest to the inertial
/// point `x`.
fn surface_of(solid: &Primitive, pose: &Pose, x: &Vector3<f64>) -> Surface {
    let local = pose.local(x);
    match solid {
        Primitive::Convex(c) => c.surface(&local),
        Primitive::Mesh(m) => m.surface(&local),
        _ => unreachable!("only convex parts and meshes have a surface query"),
    }
}

/// A sphere (or a point, radius 0) centred at inertial `x` against a convex part (with
/// its rounding) or a mesh.
fn against_surface(
    x: Vector3<f64>,
    radius: f64,
    solid: &Primitive,
    pose: &Pose,
) -> ContactGeometry {
    let s = surface_of(solid, pose, &x);
    let rounding = match solid {
        Primitive::Convex(c) => c.rounding,
        _ => 0.0,
    };
    let centre = ContactGeometry {
        gap: s.distance,
        normal: pose.dir(&s.normal),
        point1: x,
        point2: pose.point(&s.point),
    };
    inflated(centre, radius, rounding)
}

/// The contact of two shapes swept by spheres of radii `r1` (body 1's) and `r2`, from
/// that of the shapes themselves: the gap falls by both, and each point moves out of its
/// body along the normal.
fn inflated(g: ContactGeometry, r1: f64, r2: f64) -> ContactGeometry {
    ContactGeometry {
        gap: g.gap - r1 - r2,
        point1: g.point1 - g.normal * r1,
        point2: g.point2 + g.normal * r2,
        ..g
    }
}

/// A candidate out of play, placed at `at`: its gap is `OUT_OF_REACH`.
fn out_of_reach(at: Vector3<f64>) -> ContactGeometry {
    ContactGeometry {
        gap: OUT_OF_REACH,
        normal: Vector3::z(),
        point1: at,
        point2: at,
    }
}

/// Candidate `k` of a capsule (its axis `a`–`b`, radius `r`) against a convex part: its
/// two end spheres; each vertex of the part against the capsule; and the deepest point of
/// the axis and the part (GJK/EPA) where it is deeper than all of those, as where the
/// capsule lies across an edge or a narrow face.
fn capsule_convex(
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    r: f64,
    part: &ConvexPart,
    pose: &Pose,
    k: usize,
) -> ContactGeometry {
    let n = part.vertices.len();
    let on_axis = |x: &Vector3<f64>| {
        let d = b - a;
        a + d * ((x - a).dot(&d) / d.norm_squared()).clamp(0.0, 1.0)
    };
    let far = out_of_reach(*a);
    let g = match k {
        0 | 1 => {
            let x = if k == 0 { *a } else { *b };
            let s = part.surface(&pose.local(&x));
            ContactGeometry {
                gap: s.distance,
                normal: pose.dir(&s.normal),
                point1: x,
                point2: pose.point(&s.point),
            }
        }
        k if k < 2 + n => {
            let v = pose.point(&part.vertices[k - 2]);
            let p = on_axis(&v);
            let d = (p - v).norm();
            if d == 0.0 {
                return far;
            }
            ContactGeometry {
                gap: d,
                normal: (p - v) / d,
                point1: p,
                point2: v,
            }
        }
        _ => {
            let Some(g) = part.deepest_to_segment(pose, a, b) else {
                return far;
            };
            let others = (0..2 + n)
                .map(|j| capsule_convex(a, b, r, part, pose, j).gap)
                .fold(f64::MAX, f64::min);
            let tol = 1e-9 * part.size().max((b - a).norm());
            if g.gap - r - part.rounding >= others - tol {
                return far;
            }
            g
        }
    };
    inflated(g, r, part.rounding)
}

/// The point of end circle `k` of a cylinder or cone (on a body at `pose`) deepest along
/// −`n`: where the circle first meets a face of normal `n` (a cone's apex is a circle of
/// radius 0).
fn deepest_on_end(rev: &Revolution, pose: &Pose, k: usize, n: &Vector3<f64>) -> Vector3<f64> {
    let (along, radius) = rev.end(k);
    let a = pose.dir(&rev.axis);
    let end = pose.point(&(rev.center + rev.axis * along));
    // deepest rim point: the in-plane direction most opposed to the normal
    let w = -(n - a * a.dot(n));
    let w = if w.norm() > 1e-12 {
        w.normalize()
    } else {
        any_orthogonal(&a)
    };
    end + w * radius
}

/// Fixed-point steps that find where an end circle meets a convex part or a mesh: one on a
/// face, a few where the circle's deepest point crosses from one feature to the next. The
/// last point found is a material point of the circle against the surface whatever the
/// count, so its gap and normal agree with each other.
const END_CIRCLE_STEPS: usize = 8;

/// Candidate `k` of a cylinder or cone (body 1) against a convex part or a mesh (body 2),
/// without the part's rounding: its two end circles, each at its point deepest along the
/// normal of the surface there (a fixed point: the normal at the circle's deepest point
/// gives the next one; on a face, one step), so a cylinder lying on a face touches at both
/// ends and a cone at its apex and its base; against a convex part, also each vertex of
/// the part against the cylinder or cone, each edge of the part across a cylinder's side
/// (`edge_against_side`), and the part's point of the deepest pair of the two (GJK/EPA)
/// against it where that is deeper than all of those, as where an edge lies across a
/// cone's side or a cylinder's end face. The last is a point of the part against the exact
/// surface, so its normal is the round surface's, never the estimate of the search.
fn revolution_solid(
    rev: &Revolution,
    p1: &Pose,
    solid: &Primitive,
    p2: &Pose,
    k: usize,
) -> ContactGeometry {
    let far = out_of_reach(p1.x);
    // a point of the part against the cylinder or cone
    let against_round = |y: Vector3<f64>| {
        let s = rev.surface(&p1.local(&y));
        ContactGeometry {
            gap: s.distance,
            normal: -p1.dir(&s.normal),
            point1: p1.point(&s.point),
            point2: y,
        }
    };
    if k < 2 {
        let (along, _) = rev.end(k);
        let mut x = p1.point(&(rev.center + rev.axis * along));
        let mut s = surface_of(solid, p2, &x);
        let mut n = p2.dir(&s.normal);
        for _ in 0..END_CIRCLE_STEPS {
            x = deepest_on_end(rev, p1, k, &n);
            s = surface_of(solid, p2, &x);
            let next = p2.dir(&s.normal);
            let settled = (next - n).norm() <= 1e-12;
            n = next;
            if settled {
                break;
            }
        }
        return ContactGeometry {
            gap: s.distance,
            normal: n,
            point1: x,
            point2: p2.point(&s.point),
        };
    }
    let Primitive::Convex(part) = solid else {
        return far;
    };
    let nv = part.vertices.len();
    if k < 2 + nv {
        return against_round(p2.point(&part.vertices[k - 2]));
    }
    let ne = rev.side_edges(part);
    if k < 2 + nv + ne {
        let [i, j] = part.edges[k - 2 - nv];
        let (a, b) = (p2.point(&part.vertices[i]), p2.point(&part.vertices[j]));
        return edge_against_side(rev, p1, &a, &b).unwrap_or(far);
    }
    let Some(y) = part.deepest_point_against(p2, rev, p1) else {
        return far;
    };
    let g = against_round(y);
    let others = (0..2 + nv + ne)
        .map(|j| revolution_solid(rev, p1, solid, p2, j).gap)
        .fold(f64::MAX, f64::min);
    if g.gap >= others - 1e-9 * rev.size().max(part.size()) {
        return far;
    }
    g
}

/// An edge `a`–`b` (inertial) of a part against the side of a cylinder (on a body at
/// `pose`), where the two cross: the closest points of the edge's line and the axis's,
/// when they lie inside both the edge and the axis (elsewhere the part's vertices and the
/// end circles hold the contact), none where they are parallel. A cylinder lying across a
/// narrow bar rests on the bar's two edges, so it does not rock.
fn edge_against_side(
    rev: &Revolution,
    pose: &Pose,
    a: &Vector3<f64>,
    b: &Vector3<f64>,
) -> Option<ContactGeometry> {
    let p = pose.point(&(rev.center - rev.axis * rev.half_length));
    let d1 = pose.dir(&rev.axis) * (2.0 * rev.half_length);
    let d2 = b - a;
    let r = p - a;
    let (aa, bb, cc, ee, ff) = (
        d1.dot(&d1),
        d1.dot(&d2),
        d1.dot(&r),
        d2.dot(&d2),
        d2.dot(&r),
    );
    let denom = aa * ee - bb * bb;
    if denom <= 1e-12 * aa * ee {
        return None;
    }
    let s = (bb * ff - cc * ee) / denom;
    let t = (aa * ff - bb * cc) / denom;
    if s <= 0.0 || s >= 1.0 || t <= 0.0 || t >= 1.0 {
        return None;
    }
    let on_axis = p + d1 * s;
    let on_edge = a + d2 * t;
    let d = (on_axis - on_edge).norm();
    if d == 0.0 {
        return None;
    }
    let normal = (on_axis - on_edge) / d;
    Some(ContactGeometry {
        gap: d - rev.radius,
        normal,
        point1: on_axis - normal * rev.radius,
        point2: on_edge,
    })
}

/// Candidate `k` between two convex parts: a vertex of `a` against `b`, a vertex of `b`
/// against `a`, or (the last) the deepest point of the two by GJK/EPA, which holds what no
/// vertex sees: two edges crossing, or an edge lying across a face it overhangs. It is in
/// play only where it is deeper than every vertex candidate: elsewhere (a vertex on a
/// face, two faces resting on each other) it would repeat them, and a redundant point
/// wandering over a resting face leaves its friction without a unique solution.
fn convex_convex(
    a: &ConvexPart,
    p1: &Pose,
    b: &ConvexPart,
    p2: &Pose,
    k: usize,
) -> ContactGeometry {
    let g = sharp_convex_convex(a, p1, b, p2, k);
    if g.gap == OUT_OF_REACH {
        return g;
    }
    inflated(g, a.rounding, b.rounding)
}

/// `convex_convex` for the hulls themselves, without their rounding.
fn sharp_convex_convex(
    a: &ConvexPart,
    p1: &Pose,
    b: &ConvexPart,
    p2: &Pose,
    k: usize,
) -> ContactGeometry {
    let (na, nb) = (a.vertices.len(), b.vertices.len());
    if k < na {
        let x = p1.point(&a.vertices[k]);
        let s = b.surface(&p2.local(&x));
        return ContactGeometry {
            gap: s.distance,
            normal: p2.dir(&s.normal),
            point1: x,
            point2: p2.point(&s.point),
        };
    }
    if k < na + nb {
        let y = p2.point(&b.vertices[k - na]);
        let s = a.surface(&p1.local(&y));
        return ContactGeometry {
            gap: s.distance,
            normal: -p1.dir(&s.normal),
            point1: p1.point(&s.point),
            point2: y,
        };
    }
    let far = out_of_reach(p1.x);
    let Some(deepest) = a.deepest(p1, b, p2) else {
        return far;
    };
    let others = (0..na + nb)
        .map(|j| sharp_convex_convex(a, p1, b, p2, j).gap)
        .fold(f64::MAX, f64::min);
    if deepest.gap >= others - 1e-9 * a.size().max(b.size()) {
        return far;
    }
    deepest
}

/// Closest points of candidate `k` of `s1` (on a body at `p1`) against `s2` (at `p2`).
/// Pairs are ordered by `ContactPair::new`, so `s2` is a plane, a sphere or (against a
/// sphere or point) a box.
pub fn closest(s1: &Primitive, p1: &Pose, s2: &Primitive, p2: &Pose, k: usize) -> ContactGeometry {
    match (s1, s2) {
        (
            Primitive::Sphere {
                center: c1,
                radius: r1,
            },
            Primitive::Sphere {
                center: c2,
                radius: r2,
            },
        ) => {
            let x1 = p1.point(c1);
            let x2 = p2.point(c2);
            let d = x1 - x2;
            let dist = d.norm();
            let n = if dist > 0.0 { d / dist } else { Vector3::z() };
            ContactGeometry {
                gap: dist - r1 - r2,
                normal: n,
                point1: x1 - n * *r1,
                point2: x2 + n * *r2,
            }
        }
        (
            Primitive::Sphere { center: c1, radius },
            Primitive::Box {
                center,
                rotation,
                half_extents,
            },
        ) => sphere_box(p1.point(c1), *radius, p2, center, rotation, half_extents),
        (
            Primitive::Point { position },
            Primitive::Box {
                center,
                rotation,
                half_extents,
            },
        ) => sphere_box(p1.point(position), 0.0, p2, center, rotation, half_extents),
        (s1, Primitive::Plane { point, normal }) => {
            let n = p2.dir(&normal.normalize());
            let pp = p2.point(point);
            match s1 {
                Primitive::Sphere { center, radius } => {
                    point_plane(p1.point(center), pp, n, *radius)
                }
                Primitive::Point { position } => point_plane(p1.point(position), pp, n, 0.0),
                Primitive::Box {
                    center,
                    rotation,
                    half_extents: h,
                } => {
                    let s = |bit: usize| if k & bit != 0 { 1.0 } else { -1.0 };
                    let corner =
                        center + rotation * Vector3::new(s(1) * h.x, s(2) * h.y, s(4) * h.z);
                    point_plane(p1.point(&corner), pp, n, 0.0)
                }
                Primitive::Capsule {
                    center,
                    axis,
                    radius,
                    half_length,
                } => {
                    let sign = if k == 0 { -1.0 } else { 1.0 };
                    point_plane(
                        p1.point(&(center + axis.normalize() * (sign * half_length))),
                        pp,
                        n,
                        *radius,
                    )
                }
                Primitive::Cylinder { .. } | Primitive::Cone { .. } => {
                    let rev = Revolution::of(s1).expect("a cylinder or a cone");
                    point_plane(deepest_on_end(&rev, p1, k, &n), pp, n, 0.0)
                }
                Primitive::Convex(c) => point_plane(p1.point(&c.vertices[k]), pp, n, c.rounding),
                Primitive::Plane { .. } | Primitive::Profile(_) | Primitive::Mesh(_) => {
                    unreachable!(
                        "plane–plane, profile–plane and mesh–plane pairs are rejected by ContactPair::new"
                    )
                }
            }
        }
        (Primitive::Profile(a), Primitive::Profile(b)) => b.contact_profile(p2, a, p1, k),
        (pin, Primitive::Profile(profile)) => profile.contact(p2, &Pin::of(pin, p1), k).geometry,
        (
            Primitive::Sphere { center, radius },
            solid @ (Primitive::Convex(_) | Primitive::Mesh(_)),
        ) => against_surface(p1.point(center), *radius, solid, p2),
        (Primitive::Point { position }, solid @ (Primitive::Convex(_) | Primitive::Mesh(_))) => {
            against_surface(p1.point(position), 0.0, solid, p2)
        }
        (Primitive::Convex(a), solid @ Primitive::Mesh(_)) => {
            against_surface(p1.point(&a.vertices[k]), a.rounding, solid, p2)
        }
        (Primitive::Convex(a), Primitive::Convex(b)) => convex_convex(a, p1, b, p2, k),
        (
            round @ (Primitive::Cylinder { .. } | Primitive::Cone { .. }),
            solid @ (Primitive::Convex(_) | Primitive::Mesh(_)),
        ) => {
            let rev = Revolution::of(round).expect("a cylinder or a cone");
            let rounding = match solid {
                Primitive::Convex(c) => c.rounding,
                _ => 0.0,
            };
            let g = revolution_solid(&rev, p1, solid, p2, k);
            match g.gap {
                OUT_OF_REACH => g,
                _ => inflated(g, 0.0, rounding),
            }
        }
        (
            Primitive::Capsule {
                center,
                axis,
                radius,
                half_length,
            },
            Primitive::Convex(b),
        ) => {
            let along = p1.dir(&axis.normalize()) * *half_length;
            let (c, r) = (p1.point(center), *radius);
            capsule_convex(&(c - along), &(c + along), r, b, p2, k)
        }
        _ => unreachable!("unsupported pairs are rejected by ContactPair::new"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn ground() -> Primitive {
        Primitive::Plane {
            point: Vector3::zeros(),
            normal: Vector3::z(),
        }
    }

    #[test]
    fn sphere_plane_gap_and_points() {
        let p = Pose {
            x: Vector3::new(0.3, 0.0, 1.0),
            p: UnitQuaternion::identity(),
        };
        let g = closest(
            &Primitive::Sphere {
                center: Vector3::zeros(),
                radius: 0.1,
            },
            &p,
            &ground(),
            &Pose::identity(),
            0,
        );
        assert_relative_eq!(g.gap, 0.9, epsilon = 1e-15);
        assert_relative_eq!(g.point1, Vector3::new(0.3, 0.0, 0.9));
        assert_relative_eq!(g.point2, Vector3::new(0.3, 0.0, 0.0));
    }

    #[test]
    fn box_corners_on_a_tilted_plane() {
        let tilt = UnitQuaternion::from_euler_angles(0.0, 0.3, 0.0);
        let plane = Pose {
            x: Vector3::zeros(),
            p: tilt,
        };
        let body = Pose {
            x: tilt * Vector3::new(0.0, 0.0, 0.05),
            p: tilt,
        };
        let b = Primitive::Box {
            center: Vector3::zeros(),
            rotation: UnitQuaternion::identity(),
            half_extents: Vector3::new(0.1, 0.1, 0.05),
        };
        let gaps: Vec<f64> = (0..8)
            .map(|k| closest(&b, &body, &ground(), &plane, k).gap)
            .collect();
        for (k, g) in gaps.iter().enumerate() {
            let expect = if k & 4 == 0 { 0.0 } else { 0.1 };
            assert!((g - expect).abs() < 1e-15, "corner {k}: {g}");
        }
    }

    #[test]
    fn lying_cylinder_touches_with_both_rims() {
        let c = Primitive::Cylinder {
            center: Vector3::zeros(),
            axis: Vector3::z(),
            radius: 0.05,
            half_length: 0.2,
        };
        // axis along world x, centre 0.06 above the floor
        let pose = Pose {
            x: Vector3::new(0.0, 0.0, 0.06),
            p: UnitQuaternion::from_euler_angles(0.0, std::f64::consts::FRAC_PI_2, 0.0),
        };
        for k in 0..2 {
            let g = closest(&c, &pose, &ground(), &Pose::identity(), k);
            assert_relative_eq!(g.gap, 0.01, epsilon = 1e-15);
            assert_relative_eq!(g.point1.x.abs(), 0.2, epsilon = 1e-15);
        }
        // upright on its end: the deepest rim point is on the bottom circle
        let up = Pose {
            x: Vector3::new(0.0, 0.0, 0.2),
            p: UnitQuaternion::identity(),
        };
        assert_relative_eq!(
            closest(&c, &up, &ground(), &Pose::identity(), 0).gap,
            0.0,
            epsilon = 1e-15
        );
    }

    #[test]
    fn capsule_and_sphere_sphere() {
        let cap = Primitive::Capsule {
            center: Vector3::zeros(),
            axis: Vector3::x(),
            radius: 0.02,
            half_length: 0.1,
        };
        let pose = Pose {
            x: Vector3::new(0.0, 0.0, 0.5),
            p: UnitQuaternion::from_euler_angles(0.0, -0.5, 0.0),
        };
        let g0 = closest(&cap, &pose, &ground(), &Pose::identity(), 0);
        let g1 = closest(&cap, &pose, &ground(), &Pose::identity(), 1);
        assert_relative_eq!(
            g0.gap.min(g1.gap),
            0.5 - 0.1 * 0.5f64.sin() - 0.02,
            epsilon = 1e-14
        );
        let s = Primitive::Sphere {
            center: Vector3::zeros(),
            radius: 1.0,
        };
        let g = closest(
            &s,
            &Pose {
                x: Vector3::new(3.0, 4.0, 0.0),
                p: UnitQuaternion::identity(),
            },
            &s,
            &Pose::identity(),
            0,
        );
        assert_relative_eq!(g.gap, 3.0);
        assert_relative_eq!(g.normal, Vector3::new(0.6, 0.8, 0.0));
    }

    /// Sphere against a rotated, offset box on a moved body: the gap equals the distance to
    /// a brute-force sampling of the box surface (minus the radius, negative inside), the
    /// normal is the gradient of the gap (central differences), and the two points are on
    /// the two surfaces, one gap apart along the normal.
    #[test]
    fn sphere_box_matches_surface_sampling_and_gap_gradient() {
        let half = Vector3::new(0.3, 0.2, 0.1);
        let center = Vector3::new(0.05, -0.02, 0.01);
        let rotation = UnitQuaternion::from_euler_angles(0.2, -0.4, 0.7);
        let b = Primitive::Box {
            center,
            rotation,
            half_extents: half,
        };
        let body = Pose {
            x: Vector3::new(1.0, 2.0, -0.5),
            p: UnitQuaternion::from_euler_angles(-0.3, 0.1, 0.5),
        };
        let radius = 0.05;
        // the box surface as (face axis, side, u, v) in [-1, 1]²
        let face_point = |axis: usize, sign: f64, u: f64, v: f64| {
            let mut l = Vector3::zeros();
            l[axis] = sign;
            l[(axis + 1) % 3] = u.clamp(-1.0, 1.0);
            l[(axis + 2) % 3] = v.clamp(-1.0, 1.0);
            body.point(&(center + rotation * l.component_mul(&half)))
        };
        // per face: a coarse grid, then a fine grid around that face's best sample
        let sampled_distance = |x: Vector3<f64>| {
            let (n, m) = (81, 201);
            let step = 2.0 / (n - 1) as f64;
            let mut d = f64::MAX;
            for axis in 0..3 {
                for sign in [-1.0, 1.0] {
                    let mut best = (f64::MAX, 0.0, 0.0);
                    for i in 0..n {
                        for j in 0..n {
                            let (u, v) = (-1.0 + step * i as f64, -1.0 + step * j as f64);
                            let e = (x - face_point(axis, sign, u, v)).norm();
                            if e < best.0 {
                                best = (e, u, v);
                            }
                        }
                    }
                    for i in 0..m {
                        for j in 0..m {
                            let u = best.1 + step * (2.0 * i as f64 / (m - 1) as f64 - 1.0);
                            let v = best.2 + step * (2.0 * j as f64 / (m - 1) as f64 - 1.0);
                            d = d.min((x - face_point(axis, sign, u, v)).norm());
                        }
                    }
                }
            }
            d
        };
        let gap_at = |x: Vector3<f64>| {
            let sphere = Primitive::Sphere {
                center: Vector3::zeros(),
                radius,
            };
            let at = Pose {
                x,
                p: UnitQuaternion::identity(),
            };
            closest(&sphere, &at, &b, &body, 0)
        };
        let mut rng = 12345u64;
        let mut uniform = || {
            rng = rng
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (rng >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let (mut outside, mut inside) = (0, 0);
        for _ in 0..60 {
            let local =
                center + rotation * Vector3::new(0.5 * uniform(), 0.4 * uniform(), 0.3 * uniform());
            let x = body.point(&local);
            let g = gap_at(x);
            let dist = sampled_distance(x);
            let inner = {
                let l = rotation.inverse() * (local - center);
                l.x.abs() < half.x && l.y.abs() < half.y && l.z.abs() < half.z
            };
            let expected = if inner { -dist } else { dist } - radius;
            if inner {
                inside += 1
            } else {
                outside += 1
            }
            // samples are never closer than the exact closest point, and the fine grid
            // (spacing ≤ 7.5e-5 m) comes within 1e-7 of it
            let exact = if inner {
                -g.gap - radius
            } else {
                g.gap + radius
            };
            assert!(dist >= exact - 1e-12, "{dist} < {exact}");
            assert!((g.gap - expected).abs() < 1e-7, "{} vs {expected}", g.gap);
            let eps = 1e-7;
            let grad = Vector3::from_fn(|i, _| {
                let mut d = Vector3::zeros();
                d[i] = eps;
                (gap_at(x + d).gap - gap_at(x - d).gap) / (2.0 * eps)
            });
            assert!(
                (grad - g.normal).norm() < 1e-6,
                "normal {:?} vs {:?}",
                g.normal,
                grad
            );
            assert_relative_eq!(g.normal.norm(), 1.0, epsilon = 1e-12);
            assert_relative_eq!(g.point1 - g.point2, g.normal * g.gap, epsilon = 1e-12);
            assert_relative_eq!((g.point1 - x).norm(), radius, epsilon = 1e-12);
        }
        assert!(
            inside >= 5 && outside >= 30,
            "{inside} inside, {outside} outside"
        );
    }
}
