//! Analytic closest points between primitives. Each primitive is given in its body's
//! frame; `closest` returns the gap, the inertial normal (from body 2 towards body 1) and
//! the two contact points for one candidate index.

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
}

impl Primitive {
    pub fn kind(&self) -> &'static str {
        match self {
            Primitive::Sphere { .. } => "sphere",
            Primitive::Plane { .. } => "plane",
            Primitive::Box { .. } => "box",
            Primitive::Cylinder { .. } => "cylinder",
            Primitive::Capsule { .. } => "capsule",
            Primitive::Point { .. } => "point",
        }
    }

    /// Candidate points of this shape against a plane or sphere.
    pub(crate) fn candidate_count(&self) -> usize {
        match self {
            Primitive::Box { .. } => 8,
            Primitive::Cylinder { .. } | Primitive::Capsule { .. } => 2,
            _ => 1,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
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

/// Closest points of candidate `k` of `s1` (on a body at `p1`) against `s2` (at `p2`).
/// Pairs are ordered by `ContactPair::new`, so `s2` is a plane or a sphere.
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
                Primitive::Cylinder {
                    center,
                    axis,
                    radius,
                    half_length,
                } => {
                    let sign = if k == 0 { -1.0 } else { 1.0 };
                    let a = p1.dir(&axis.normalize());
                    let end = p1.point(&(center + axis.normalize() * (sign * half_length)));
                    // deepest rim point: the in-plane direction most opposed to the normal
                    let w = -(n - a * a.dot(&n));
                    let w = if w.norm() > 1e-12 {
                        w.normalize()
                    } else {
                        any_orthogonal(&a)
                    };
                    point_plane(end + w * *radius, pp, n, 0.0)
                }
                Primitive::Plane { .. } => {
                    unreachable!("plane–plane pairs are rejected by ContactPair::new")
                }
            }
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
}
