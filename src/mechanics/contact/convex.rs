//! Convex parts: a convex polyhedron in its body's frame, the hull of a vertex list or of
//! a mesh file, built with parry's convex hull. Its contacts are exact where they matter
//! to a resting part: its vertices against a plane or another solid (a flat face on a flat
//! face touches at every corner, so it does not rock), a pin's centre against its faces,
//! and, between two convex parts, the deepest point that parry's GJK/EPA finds, which
//! covers two edges crossing and an edge lying across a face. parry's own types stay inside this module and `mesh.rs`.

use nalgebra::Vector3;
use parry3d_f64::math::Vector as PVector;

/// The nalgebra vector of a parry one, and back.
pub(super) fn from_parry(v: PVector) -> Vector3<f64> {
    Vector3::new(v.x, v.y, v.z)
}

pub(super) fn to_parry(v: &Vector3<f64>) -> PVector {
    PVector::new(v.x, v.y, v.z)
}

#[derive(Clone, Debug)]
pub struct ConvexPart {
    /// Hull vertices, body frame.
    pub vertices: Vec<Vector3<f64>>,
    /// Radius of the sphere swept over the hull (0: sharp): a part with rounded edges
    /// and corners, whose every candidate gap is the hull's less this radius.
    pub rounding: f64,
    /// Hull triangles (outward, counter-clockwise), as vertex indices.
    triangles: Vec<[usize; 3]>,
    /// Each triangle's outward unit normal and offset: n · x = d on its plane.
    planes: Vec<(Vector3<f64>, f64)>,
    /// The hull's edges, as vertex pairs: where two faces meet at an angle (the diagonals
    /// that split a flat face into triangles are not edges).
    pub edges: Vec<[usize; 2]>,
    /// The same hull as parry's shape, for GJK/EPA.
    shape: parry3d_f64::shape::ConvexPolyhedron,
}

impl PartialEq for ConvexPart {
    fn eq(&self, other: &Self) -> bool {
        self.vertices == other.vertices
            && self.triangles == other.triangles
            && self.rounding == other.rounding
    }
}

/// The closest boundary point of a solid to a point, with the signed distance (< 0 inside)
/// and the outward unit normal there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    pub distance: f64,
    pub point: Vector3<f64>,
    pub normal: Vector3<f64>,
}

impl ConvexPart {
    /// The hull of `points` (body frame). With `exact`, every point must be a vertex of
    /// the hull: a point inside it means the list was not the vertex set of a convex part.
    pub fn new(points: &[Vector3<f64>], exact: bool) -> Result<ConvexPart, String> {
        if points.len() < 4 {
            return Err(format!(
                "a convex part needs at least 4 points, got {}",
                points.len()
            ));
        }
        if let Some(k) = points.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
            return Err(format!(
                "point {k} has a coordinate that is not a finite number: {:?}",
                points[k].as_slice()
            ));
        }
        let scale = points.iter().map(|p| p.norm()).fold(0.0, f64::max);
        let pts: Vec<PVector> = points.iter().map(to_parry).collect();
        let (hull, tris) = parry3d_f64::transformation::try_convex_hull(&pts)
            .map_err(|e| format!("no convex hull: {e:?} (are the points coplanar?)"))?;
        let vertices: Vec<Vector3<f64>> = hull.into_iter().map(from_parry).collect();
        let triangles: Vec<[usize; 3]> = tris
            .iter()
            .map(|t| [t[0] as usize, t[1] as usize, t[2] as usize])
            .collect();
        let volume: f64 = triangles
            .iter()
            .map(|t| vertices[t[0]].dot(&vertices[t[1]].cross(&vertices[t[2]])) / 6.0)
            .sum();
        if volume <= 1e-12 * scale.powi(3) {
            return Err("the hull is flat: the points span no volume".into());
        }
        let mut planes = Vec::with_capacity(triangles.len());
        for t in &triangles {
            let [a, b, c] = t.map(|i| vertices[i]);
            let n = (b - a).cross(&(c - a));
            if n.norm() <= 1e-12 * scale * scale {
                return Err("the hull is flat: the points span no volume".into());
            }
            let n = n.normalize();
            planes.push((n, n.dot(&a)));
        }
        // relative to the part's own size: a binary STL rounds each coordinate to 32 bits,
        // which leaves a convex part's vertices up to about 1e-7 of that size off its faces
        let centre = points.iter().sum::<Vector3<f64>>() / points.len() as f64;
        let size = points
            .iter()
            .map(|p| (p - centre).norm())
            .fold(0.0, f64::max);
        let tolerance =
            (1e-6 * size + 4.0 * f64::from(f32::EPSILON) * centre.norm()).max(f64::MIN_POSITIVE);
        if exact {
            let inside: Vec<usize> = points
                .iter()
                .enumerate()
                .filter(|(_, p)| {
                    !vertices.iter().any(|v| (*v - **p).norm() <= tolerance)
                        && planes.iter().all(|(n, d)| n.dot(p) - d < -tolerance)
                })
                .map(|(i, _)| i)
                .collect();
            if !inside.is_empty() {
                return Err(format!(
                    "the points are not convex: {} of them lie inside the hull of the others (points {:?})",
                    inside.len(),
                    inside
                ));
            }
        }
        let shape = parry3d_f64::shape::ConvexPolyhedron::from_convex_hull(&pts)
            .ok_or("parry cannot build the convex polyhedron")?;
        // each side of each triangle, with the triangle; a hull's side is shared by two
        let mut sides: Vec<([usize; 2], usize)> = triangles
            .iter()
            .enumerate()
            .flat_map(|(k, t)| {
                (0..3).map(move |j| {
                    let (a, b) = (t[j], t[(j + 1) % 3]);
                    ([a.min(b), a.max(b)], k)
                })
            })
            .collect();
        sides.sort_unstable();
        let edges = sides
            .chunks(2)
            .filter(|pair| {
                pair.len() == 2 && planes[pair[0].1].0.dot(&planes[pair[1].1].0) < 1.0 - 1e-9
            })
            .map(|pair| pair[0].0)
            .collect();
        Ok(ConvexPart {
            vertices,
            rounding: 0.0,
            triangles,
            planes,
            edges,
            shape,
        })
    }

    /// The distance of its farthest vertex from its body's origin: the length scale of
    /// its tolerances.
    pub fn size(&self) -> f64 {
        self.vertices.iter().map(|v| v.norm()).fold(0.0, f64::max)
    }

    /// The same hull with its edges and corners rounded by `radius`.
    pub fn rounded(self, radius: f64) -> ConvexPart {
        ConvexPart {
            rounding: radius,
            ..self
        }
    }

    /// The closest boundary point to `x` (body frame).
    pub fn surface(&self, x: &Vector3<f64>) -> Surface {
        let (deepest, k_deepest) = self
            .planes
            .iter()
            .enumerate()
            .map(|(k, (n, d))| (n.dot(x) - d, k))
            .fold((f64::MIN, 0), |a, b| if b.0 > a.0 { b } else { a });
        if deepest <= 0.0 {
            // inside: out through the nearest face plane, which is on the hull
            let n = self.planes[k_deepest].0;
            return Surface {
                distance: deepest,
                point: x - n * deepest,
                normal: n,
            };
        }
        let mut best = (f64::MAX, Vector3::zeros(), 0, false);
        for (k, t) in self.triangles.iter().enumerate() {
            if self.planes[k].0.dot(x) - self.planes[k].1 < 0.0 {
                continue; // a face turned away cannot hold the closest point of an outside point
            }
            let (p, interior) = closest_on_triangle(x, &t.map(|i| self.vertices[i]));
            let d = (x - p).norm_squared();
            if d < best.0 {
                best = (d, p, k, interior);
            }
        }
        let (d2, point, k, interior) = best;
        // a point over a side shared by two triangles of one flat face (or over the
        // face's own plane within round-off) has that face's normal, not the direction from
        // the side: a corner resting on a face's diagonal would otherwise push sideways
        let on_plane = !interior && deepest >= d2.sqrt() - 1e-12 * self.size();
        let plane =
            (interior || on_plane).then(|| self.planes[if on_plane { k_deepest } else { k }]);
        surface_at(x, point, plane)
    }

    /// The deepest (or closest) pair of points between this part at pose `p1` and `other`
    /// at `p2`, by parry's GJK/EPA, as a contact with this part as body 1.
    pub fn deepest(
        &self,
        p1: &crate::mechanics::Pose,
        other: &ConvexPart,
        p2: &crate::mechanics::Pose,
    ) -> Option<super::ContactGeometry> {
        let c = parry3d_f64::query::details::contact_support_map_support_map(
            &relative(p1, p2),
            &self.shape,
            &other.shape,
            f64::MAX,
        )?;
        Some(geometry(&c, p1, p2))
    }

    /// The point of this part (at `pose`) in the deepest (or closest) pair of points between
    /// it and a cylinder or cone (on a body at `round_pose`), by parry's GJK/EPA; inertial.
    pub fn deepest_point_against(
        &self,
        pose: &crate::mechanics::Pose,
        round: &super::revolution::Revolution,
        round_pose: &crate::mechanics::Pose,
    ) -> Option<Vector3<f64>> {
        // parry's cylinders and cones stand along their y axis, centred
        let upright = nalgebra::UnitQuaternion::rotation_between(&Vector3::y(), &round.axis)
            .unwrap_or_else(|| {
                nalgebra::UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
            });
        let frame = crate::mechanics::Pose {
            x: round_pose.point(&round.center),
            p: round_pose.p * upright,
        };
        let (h, r) = (round.half_length, round.radius);
        let (cone, cylinder) = (
            parry3d_f64::shape::Cone::new(h, r),
            parry3d_f64::shape::Cylinder::new(h, r),
        );
        let shape: &dyn parry3d_f64::shape::SupportMap = match round.cone {
            true => &cone,
            false => &cylinder,
        };
        let c = parry3d_f64::query::details::contact_support_map_support_map(
            &relative(&frame, pose),
            shape,
            &self.shape,
            f64::MAX,
        )?;
        Some(pose.point(&from_parry(c.point2)))
    }

    /// The deepest (or closest) pair of points between the segment `a`–`b` (inertial) and
    /// this part at `pose`, by parry's GJK/EPA, as a contact with the segment as body 1:
    /// the point on the segment, the point on the part, the normal from the part towards
    /// the segment and the signed distance (the rounding not taken off).
    pub fn deepest_to_segment(
        &self,
        pose: &crate::mechanics::Pose,
        a: &Vector3<f64>,
        b: &Vector3<f64>,
    ) -> Option<super::ContactGeometry> {
        let local = |x: &Vector3<f64>| to_parry(&pose.local(x));
        let segment = parry3d_f64::shape::Segment::new(local(a), local(b));
        let c = parry3d_f64::query::details::contact_support_map_support_map(
            &parry3d_f64::math::Pose::IDENTITY,
            &segment,
            &self.shape,
            f64::MAX,
        )?;
        Some(geometry(&c, pose, pose))
    }
}

/// The pose of frame `p2` relative to frame `p1`, as parry's `pos12`: it maps points of
/// shape 2's frame into shape 1's.
fn relative(p1: &crate::mechanics::Pose, p2: &crate::mechanics::Pose) -> parry3d_f64::math::Pose {
    let q = (p1.p.inverse() * p2.p).into_inner();
    parry3d_f64::math::Pose::from_parts(
        to_parry(&p1.local(&p2.x)),
        parry3d_f64::math::Rotation::from_xyzw(q.i, q.j, q.k, q.w),
    )
}

/// A parry contact between shapes 1 and 2 (their points in their own frames, at poses `p1`
/// and `p2`) as our geometry: parry's normal1 points out of shape 1 towards shape 2; ours,
/// from body 2 towards body 1, the other way.
fn geometry(
    c: &parry3d_f64::query::Contact,
    p1: &crate::mechanics::Pose,
    p2: &crate::mechanics::Pose,
) -> super::ContactGeometry {
    super::ContactGeometry {
        gap: c.dist,
        normal: -p1.dir(&from_parry(c.normal1)),
        point1: p1.point(&from_parry(c.point1)),
        point2: p2.point(&from_parry(c.point2)),
    }
}

/// The surface point `point` closest to the outside point `x`: on a face (its `plane`
/// given) the normal is the face's, exact however close `x` is; on an edge or a vertex it
/// is the direction from the point to `x`.
pub(super) fn surface_at(
    x: &Vector3<f64>,
    point: Vector3<f64>,
    plane: Option<(Vector3<f64>, f64)>,
) -> Surface {
    if let Some((n, d)) = plane {
        let distance = n.dot(x) - d;
        return Surface {
            distance,
            point: x - n * distance,
            normal: n,
        };
    }
    let d = (x - point).norm();
    Surface {
        distance: d,
        point,
        normal: if d > 0.0 {
            (x - point) / d
        } else {
            Vector3::z()
        },
    }
}

/// The point of triangle `t` closest to `x`, and whether it is inside the face rather
/// than on an edge or a vertex (Ericson, Real-Time Collision Detection 5.1.5).
pub(super) fn closest_on_triangle(x: &Vector3<f64>, t: &[Vector3<f64>; 3]) -> (Vector3<f64>, bool) {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, x - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, false);
    }
    let bp = x - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (b, false);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return (a + ab * (d1 / (d1 - d3)), false);
    }
    let cp = x - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (c, false);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return (a + ac * (d2 / (d2 - d6)), false);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))), false);
    }
    let denom = 1.0 / (va + vb + vc);
    (a + ab * (vb * denom) + ac * (vc * denom), true)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanics::contact::{ContactPair, Primitive};
    use crate::mechanics::Pose;
    use nalgebra::UnitQuaternion;
    use std::f64::consts::FRAC_PI_4;

    /// The 8 corners of a box centred at the origin with half extents (x, y, z).
    fn box_corners(x: f64, y: f64, z: f64) -> Vec<Vector3<f64>> {
        (0..8)
            .map(|k| {
                let s = |bit: usize, e: f64| if k & bit != 0 { e } else { -e };
                Vector3::new(s(1, x), s(2, y), s(4, z))
            })
            .collect()
    }

    fn cube() -> Primitive {
        Primitive::Convex(Box::new(
            ConvexPart::new(&box_corners(0.5, 0.5, 0.5), true).unwrap(),
        ))
    }

    /// Two unit cubes, one turned 45° about x resting on its bottom edge, the other turned
    /// 45° about y with its top edge up: the edges cross, `d` apart. No vertex is near
    /// the other cube; the deepest-point candidate finds the gap, apart or overlapping.
    #[test]
    fn crossing_edges_are_found_by_the_deepest_point() {
        let r = 0.5 * 2f64.sqrt();
        for d in [0.01, 1e-6, -1e-3] {
            let poses = [
                Pose {
                    x: Vector3::new(0.0, 0.0, r + d),
                    p: UnitQuaternion::from_euler_angles(FRAC_PI_4, 0.0, 0.0),
                },
                Pose {
                    x: Vector3::new(0.0, 0.0, -r),
                    p: UnitQuaternion::from_euler_angles(0.0, FRAC_PI_4, 0.0),
                },
            ];
            let pair = ContactPair::new("x", Some(0), cube(), Some(1), cube(), 0.0, 0.0).unwrap();
            let n = pair.candidates();
            assert_eq!(n, 17);
            let gaps: Vec<f64> = (0..n).map(|k| pair.evaluate(k, &poses).gap()).collect();
            let vertices = gaps[..16].iter().cloned().fold(f64::MAX, f64::min);
            assert!(vertices > 0.3, "{vertices}");
            let edge = pair.evaluate(16, &poses);
            assert!((edge.gap() - d).abs() < 1e-9, "d = {d}: {}", edge.gap());
            assert!(
                (edge.normal() - Vector3::z()).norm() < 1e-6,
                "{:?}",
                edge.normal()
            );
        }
        // an edge lying across a narrow beam's top face, overhanging it on both sides: no
        // vertex of either touches, the deepest point does
        let beam = Primitive::Convex(Box::new(
            ConvexPart::new(&box_corners(0.1, 1.0, 0.5), true).unwrap(),
        ));
        for d in [0.01, -1e-3] {
            let poses = [
                Pose {
                    x: Vector3::new(0.0, 0.0, 0.5 + r + d),
                    p: UnitQuaternion::from_euler_angles(FRAC_PI_4, 0.0, 0.0),
                },
                Pose::identity(),
            ];
            let pair =
                ContactPair::new("x", Some(0), cube(), Some(1), beam.clone(), 0.0, 0.0).unwrap();
            let gaps: Vec<f64> = (0..17).map(|k| pair.evaluate(k, &poses).gap()).collect();
            let vertices = gaps[..16].iter().cloned().fold(f64::MAX, f64::min);
            assert!(vertices > 0.1, "{vertices}");
            assert!((gaps[16] - d).abs() < 1e-9, "d = {d}: {}", gaps[16]);
        }
        // a vertex resting on a face: the deepest point is that vertex, left to its own
        // candidate
        let poses = [
            Pose {
                x: Vector3::new(0.1, 0.2, 0.5 + 0.5 * 3f64.sqrt()),
                p: UnitQuaternion::rotation_between(&Vector3::repeat(-1.0), &-Vector3::z())
                    .unwrap(),
            },
            Pose::identity(),
        ];
        let pair = ContactPair::new("x", Some(0), cube(), Some(1), cube(), 0.0, 0.0).unwrap();
        let gaps: Vec<f64> = (0..17).map(|k| pair.evaluate(k, &poses).gap()).collect();
        assert_eq!(gaps[16], crate::mechanics::contact::profile::OUT_OF_REACH);
        assert_eq!(
            gaps.iter().filter(|g| g.abs() < 1e-12).count(),
            1,
            "{gaps:?}"
        );
    }

    /// The signed distance of points to a tetrahedron against the planes and a brute-force
    /// sampling of its faces.
    #[test]
    fn surface_distance_matches_sampling() {
        let pts = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, 1.0, 0.0),
            Vector3::new(0.0, 0.0, 1.0),
        ];
        let tet = ConvexPart::new(&pts, true).unwrap();
        let faces = [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]];
        let n = 400;
        for x in [
            Vector3::new(0.2, 0.2, 0.2),
            Vector3::new(1.0, 1.0, 1.0),
            Vector3::new(-0.3, 0.4, 0.1),
            Vector3::new(2.0, -1.0, 0.5),
            Vector3::new(-0.1, -0.1, -0.1),
            Vector3::new(0.05, 0.05, 0.6),
        ] {
            let s = tet.surface(&x);
            let mut best = f64::MAX;
            for f in faces {
                for i in 0..=n {
                    for j in 0..=(n - i) {
                        let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                        let p =
                            pts[f[0]] + (pts[f[1]] - pts[f[0]]) * u + (pts[f[2]] - pts[f[0]]) * v;
                        best = best.min((x - p).norm());
                    }
                }
            }
            // the grid's spacing bounds the sampling error
            assert!(
                (s.distance.abs() - best).abs() < 2e-3,
                "{x:?}: {} vs {best}",
                s.distance
            );
            assert!((x - s.point).norm() - s.distance.abs() < 1e-12);
            let inside = x.iter().all(|&c| c > 0.0) && x.sum() < 1.0;
            assert_eq!(s.distance < 0.0, inside, "{x:?}");
        }
    }
    /// A rounded part is the hull swept by a sphere: every gap falls by the radius, to a
    /// plane, to a sphere near a face and near a corner, and between crossing edges.
    #[test]
    fn rounding_lowers_every_gap_by_its_radius() {
        let r = 0.01;
        let rounded = || match cube() {
            Primitive::Convex(c) => Primitive::Convex(Box::new(c.rounded(r))),
            _ => unreachable!(),
        };
        let plane = Primitive::Plane {
            point: Vector3::zeros(),
            normal: Vector3::z(),
        };
        let at = |z: f64| Pose {
            x: Vector3::new(0.0, 0.0, z),
            p: UnitQuaternion::identity(),
        };
        let on_plane = ContactPair::new("p", Some(0), rounded(), None, plane, 0.0, 0.0).unwrap();
        let lowest = (0..8)
            .map(|k| on_plane.evaluate(k, &[at(0.6)]).gap())
            .fold(f64::MAX, f64::min);
        assert!((lowest - (0.1 - r)).abs() < 1e-15, "{lowest}");
        let ball = Primitive::Sphere {
            center: Vector3::zeros(),
            radius: 0.1,
        };
        let pair = ContactPair::new("s", Some(1), ball, Some(0), rounded(), 0.0, 0.0).unwrap();
        let sphere_at = |x: Vector3<f64>| {
            let poses = [
                Pose::identity(),
                Pose {
                    x,
                    p: UnitQuaternion::identity(),
                },
            ];
            pair.evaluate(0, &poses).gap()
        };
        // above a face, and off a corner along the diagonal
        assert!((sphere_at(Vector3::new(0.1, 0.2, 0.8)) - (0.3 - 0.1 - r)).abs() < 1e-15);
        let corner = Vector3::repeat(0.5);
        let x = corner + Vector3::repeat(1.0).normalize() * 0.4;
        assert!((sphere_at(x) - (0.4 - 0.1 - r)).abs() < 1e-14);
        // crossing edges, 0.05 apart between the hulls
        let s2 = 0.5 * 2f64.sqrt();
        let poses = [
            Pose {
                x: Vector3::new(0.0, 0.0, s2 + 0.05),
                p: UnitQuaternion::from_euler_angles(FRAC_PI_4, 0.0, 0.0),
            },
            Pose {
                x: Vector3::new(0.0, 0.0, -s2),
                p: UnitQuaternion::from_euler_angles(0.0, FRAC_PI_4, 0.0),
            },
        ];
        let edges =
            ContactPair::new("e", Some(0), rounded(), Some(1), rounded(), 0.0, 0.0).unwrap();
        let g = edges.evaluate(16, &poses);
        assert!((g.gap() - (0.05 - 2.0 * r)).abs() < 1e-9, "{}", g.gap());
        assert!((g.geometry.point1 - g.geometry.point2).norm() - g.gap() < 1e-9);
    }
    /// A capsule lying on a cube's face touches with both end spheres; lying across a
    /// narrow beam it touches with the middle of its axis, which the deepest point finds;
    /// a cube's corner pressed on its side is that vertex's candidate.
    #[test]
    fn a_capsule_meets_a_convex_part_at_its_ends_its_middle_and_its_side() {
        let capsule = Primitive::Capsule {
            center: Vector3::zeros(),
            axis: Vector3::x(),
            radius: 0.05,
            half_length: 0.3,
        };
        let at = |x: Vector3<f64>| Pose {
            x,
            p: UnitQuaternion::identity(),
        };
        let pair = |part: Primitive| {
            ContactPair::new("c", Some(0), capsule.clone(), Some(1), part, 0.0, 0.0).unwrap()
        };
        let gaps = |pair: &ContactPair, poses: &[Pose]| -> Vec<f64> {
            (0..pair.candidates())
                .map(|k| pair.evaluate(k, poses).gap())
                .collect()
        };
        // a 2 m slab, its top at z = 0.5: both ends 0.01 above it
        let on_slab = pair(Primitive::Convex(Box::new(
            ConvexPart::new(&box_corners(1.0, 1.0, 0.5), true).unwrap(),
        )));
        assert_eq!(on_slab.candidates(), 11);
        let g = gaps(
            &on_slab,
            &[at(Vector3::new(0.0, 0.0, 0.56)), Pose::identity()],
        );
        assert!(
            (g[0] - 0.01).abs() < 1e-15 && (g[1] - 0.01).abs() < 1e-15,
            "{g:?}"
        );
        // the same slab as a box: taken as the convex part of its corners
        let on_box = pair(Primitive::Box {
            center: Vector3::zeros(),
            rotation: UnitQuaternion::identity(),
            half_extents: Vector3::new(1.0, 1.0, 0.5),
        });
        assert_eq!(on_box.candidates(), 11);
        let h = gaps(
            &on_box,
            &[at(Vector3::new(0.0, 0.0, 0.56)), Pose::identity()],
        );
        assert!(
            (h[0] - 0.01).abs() < 1e-15 && (h[1] - 0.01).abs() < 1e-15,
            "{h:?}"
        );
        // across a beam 0.2 wide: only the middle touches
        let across = pair(Primitive::Convex(Box::new(
            ConvexPart::new(&box_corners(0.1, 1.0, 0.5), true).unwrap(),
        )));
        let g = gaps(
            &across,
            &[at(Vector3::new(0.0, 0.0, 0.56)), Pose::identity()],
        );
        let ends_and_vertices = g[..10].iter().cloned().fold(f64::MAX, f64::min);
        assert!(ends_and_vertices > 0.05, "{g:?}");
        assert!((g[10] - 0.01).abs() < 1e-9, "{g:?}");
        // a cube's corner 0.02 below the capsule's side
        let cube_pose = Pose {
            x: Vector3::new(0.1, 0.0, -0.07 - 0.5 * 3f64.sqrt()),
            p: UnitQuaternion::rotation_between(&Vector3::repeat(1.0), &Vector3::z()).unwrap(),
        };
        let corner = pair(cube());
        let g = gaps(&corner, &[at(Vector3::zeros()), cube_pose]);
        let least = g.iter().cloned().fold(f64::MAX, f64::min);
        assert!((least - 0.02).abs() < 1e-12, "{g:?}");
    }
}
