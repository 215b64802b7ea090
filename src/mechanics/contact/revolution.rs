//! Cylinders and cones: solids of revolution about an axis, whose meridian section is a
//! rectangle or a triangle. The closest surface point to a point lies in the point's
//! meridian plane, so the 3-D query is the 2-D one on that section, and exact. Against a
//! face, each end circle touches at its point deepest along the face's normal (a cone's
//! apex is a circle of radius 0): a cylinder lying on a face touches at both ends, a cone
//! lying on a face at its apex and its base.

use super::convex::Surface;
use super::Primitive;
use crate::math::any_orthogonal;
use nalgebra::{Vector2, Vector3};

/// A cylinder or a cone in its body's frame. The cone's base is at −`half_length` along
/// `axis` from `center`, its apex at +`half_length`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Revolution {
    pub center: Vector3<f64>,
    /// Unit axis.
    pub axis: Vector3<f64>,
    pub half_length: f64,
    pub radius: f64,
    pub cone: bool,
}

impl Revolution {
    /// The cylinder or cone a primitive is, if it is one.
    pub fn of(shape: &Primitive) -> Option<Revolution> {
        let (center, axis, radius, half_length, cone) = match shape {
            Primitive::Cylinder {
                center,
                axis,
                radius,
                half_length,
            } => (center, axis, radius, half_length, false),
            Primitive::Cone {
                center,
                axis,
                radius,
                half_length,
            } => (center, axis, radius, half_length, true),
            _ => return None,
        };
        Some(Revolution {
            center: *center,
            axis: axis.normalize(),
            half_length: *half_length,
            radius: *radius,
            cone,
        })
    }

    /// End circle `k` (0 at −half_length, 1 at +half_length): its centre along the axis
    /// from `center`, and its radius (0 at a cone's apex).
    pub fn end(&self, k: usize) -> (f64, f64) {
        match k {
            0 => (-self.half_length, self.radius),
            _ if self.cone => (self.half_length, 0.0),
            _ => (self.half_length, self.radius),
        }
    }

    /// How many of a convex part's edges are candidates against its side: all of them
    /// against a cylinder's (`primitives::edge_against_side`), none against a cone's, which
    /// the deepest point of the two covers.
    pub fn side_edges(&self, part: &super::convex::ConvexPart) -> usize {
        if self.cone {
            0
        } else {
            part.edges.len()
        }
    }

    /// The distance of its farthest point from its body's origin: the length scale of its
    /// tolerances.
    pub fn size(&self) -> f64 {
        self.center.norm() + self.half_length.hypot(self.radius)
    }

    /// The closest surface point to `x` (body frame), with the signed distance (< 0 inside)
    /// and the outward normal: the 2-D query on the meridian section through `x`, in the
    /// coordinates (ρ, z) of distance from the axis and height along it.
    pub fn surface(&self, x: &Vector3<f64>) -> Surface {
        let d = x - self.center;
        let z = d.dot(&self.axis);
        let radial = d - self.axis * z;
        let rho = radial.norm();
        let e = if rho > 0.0 {
            radial / rho
        } else {
            any_orthogonal(&self.axis)
        };
        let p = Vector2::new(rho, z);
        let (l, r0, r1) = (self.half_length, self.end(0).1, self.end(1).1);
        // the whole section, counter-clockwise; a cone's top edge has length 0
        let corners = [
            Vector2::new(-r0, -l),
            Vector2::new(r0, -l),
            Vector2::new(r1, l),
            Vector2::new(-r1, l),
        ];
        let edges = (0..4)
            .map(|i| (corners[i], corners[(i + 1) % 4]))
            .filter(|(a, b)| a != b);
        let mut deepest = (f64::MIN, Vector2::zeros());
        let mut nearest = (f64::MAX, Vector2::zeros(), Vector2::zeros());
        for (a, b) in edges {
            let t = b - a;
            let n = Vector2::new(t.y, -t.x).normalize();
            let s = n.dot(&(p - a));
            if s > deepest.0 {
                deepest = (s, n);
            }
            if s > 0.0 {
                let u = ((p - a).dot(&t) / t.norm_squared()).clamp(0.0, 1.0);
                let q = a + t * u;
                let dist = (p - q).norm();
                if dist < nearest.0 {
                    // on the edge's interior the normal is the edge's, exact however close
                    // p is; at a corner it points from the corner to p
                    let normal = if u > 0.0 && u < 1.0 {
                        n
                    } else {
                        (p - q) / dist
                    };
                    let dist = if u > 0.0 && u < 1.0 { s } else { dist };
                    nearest = (dist, q, normal);
                }
            }
        }
        let to_3d = |v: Vector2<f64>| e * v.x + self.axis * v.y;
        let (distance, point, normal) = if deepest.0 <= 0.0 {
            // inside: out through the nearest side
            (deepest.0, p - deepest.1 * deepest.0, deepest.1)
        } else {
            nearest
        };
        Surface {
            distance,
            point: self.center + to_3d(point),
            normal: to_3d(normal),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use parry3d_f64::math::Vector as PVector;
    use parry3d_f64::query::PointQuery;

    /// Closest points against parry's own point projection on its cylinder and cone (axis
    /// y, centred), for points outside and inside, near the ends, the rims, the axis and
    /// the apex: the distance to 1e-12 m, a surface point at that distance, and the normal
    /// along the direction from the surface point for outside points.
    #[test]
    fn closest_points_match_parry_projection() {
        let (r, l) = (0.02, 0.05);
        let cylinder = parry3d_f64::shape::Cylinder::new(l, r);
        let cone = parry3d_f64::shape::Cone::new(l, r);
        let mut checked = 0;
        for is_cone in [false, true] {
            let rev = Revolution {
                center: Vector3::zeros(),
                axis: Vector3::y(),
                half_length: l,
                radius: r,
                cone: is_cone,
            };
            for i in 0..21 {
                for j in 0..21 {
                    for phi in [0.0, 1.0, 2.5] {
                        let rho = 0.04 * i as f64 / 20.0 + 1e-3 * (j % 3) as f64;
                        let y = -0.08 + 0.16 * j as f64 / 20.0;
                        let x = Vector3::new(rho * f64::cos(phi), y, rho * f64::sin(phi));
                        let s = rev.surface(&x);
                        let px = PVector::new(x.x, x.y, x.z);
                        let proj = if is_cone {
                            cone.project_local_point(px, false)
                        } else {
                            cylinder.project_local_point(px, false)
                        };
                        let q = Vector3::new(proj.point.x, proj.point.y, proj.point.z);
                        let expected = (x - q).norm() * if proj.is_inside { -1.0 } else { 1.0 };
                        assert!(
                            (s.distance - expected).abs() < 1e-12,
                            "cone {is_cone}, {x:?}: {} against parry's {expected}",
                            s.distance
                        );
                        // the point is on the surface, at that distance (parry's point
                        // may be another one where two sides are equally near)
                        assert!(rev.surface(&s.point).distance.abs() < 1e-12, "{x:?}");
                        assert!(((x - s.point).norm() - s.distance.abs()).abs() < 1e-12);
                        assert!((s.normal.norm() - 1.0).abs() < 1e-12);
                        if s.distance > 1e-9 {
                            let along = (x - s.point) / s.distance;
                            assert!((along - s.normal).norm() < 1e-9, "{x:?}");
                        }
                        checked += 1;
                    }
                }
            }
        }
        assert_eq!(checked, 2 * 21 * 21 * 3);
    }

    /// A cone, or a cylinder, lying on its side with its lowest line at height z₀, above a
    /// bar 4 mm wide that crosses that line, its top face `d` below it: no end circle and no
    /// corner of the bar comes near, and the smallest candidate gap is `d`, found by the
    /// bar's edges against the cylinder and by the deepest point (GJK/EPA) against the cone,
    /// apart or overlapping.
    #[test]
    fn a_bar_across_the_side_is_found_apart_and_overlapping() {
        use crate::mechanics::contact::{ContactPair, Primitive};
        use crate::mechanics::Pose;
        use nalgebra::UnitQuaternion;
        let (r, l, z0) = (0.02_f64, 0.04_f64, 0.3);
        let bar = Primitive::Box {
            center: Vector3::zeros(),
            rotation: UnitQuaternion::identity(),
            half_extents: Vector3::new(0.002, 0.1, 0.05),
        };
        for cone in [true, false] {
            // the cone's axis (base to apex) rises by β from its lowest line; the cylinder's
            // is level
            let beta = if cone { (r / l).atan() } else { 0.0 };
            let axis = Vector3::new(-beta.cos(), 0.0, -beta.sin());
            let middle = if cone {
                Vector3::new(0.0, 0.0, z0) - axis * (0.5 * l)
            } else {
                Vector3::new(0.5 * l, 0.0, z0 + r)
            };
            let (shape, across) = match cone {
                true => (
                    Primitive::Cone {
                        center: Vector3::zeros(),
                        axis: Vector3::z(),
                        radius: r,
                        half_length: 0.5 * l,
                    },
                    0.5 * l.hypot(r),
                ),
                false => (
                    Primitive::Cylinder {
                        center: Vector3::zeros(),
                        axis: Vector3::z(),
                        radius: r,
                        half_length: 0.5 * l,
                    },
                    0.5 * l,
                ),
            };
            let pair =
                ContactPair::new("c", Some(0), shape, Some(1), bar.clone(), 0.0, 0.0).unwrap();
            for d in [0.01, 1e-6, -1e-4] {
                let poses = [
                    Pose {
                        x: middle,
                        p: UnitQuaternion::rotation_between(&Vector3::z(), &axis).unwrap(),
                    },
                    Pose {
                        x: Vector3::new(across, 0.0, z0 - d - 0.05),
                        p: UnitQuaternion::identity(),
                    },
                ];
                let gaps: Vec<f64> = (0..pair.candidates())
                    .map(|k| pair.evaluate(k, &poses).gap())
                    .collect();
                let least = gaps.iter().copied().fold(f64::MAX, f64::min);
                assert!(
                    (least - d).abs() < 1e-9,
                    "cone {cone}, d = {d}: least gap {least} ({gaps:?})"
                );
                // only the side reaches the bar: not the end circles, not the corners
                assert!(gaps[0] > 0.005 && gaps[1] > 0.005, "cone {cone}: {gaps:?}");
                assert!(
                    gaps[2..10].iter().all(|&g| g > 0.005),
                    "cone {cone}: {gaps:?}"
                );
            }
        }
    }
}
