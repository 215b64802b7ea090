//! Planar profiles: a chain of line segments and circular arcs drawn in a plane of a body
//! and extruded along the plane's normal over a thickness. Most mechanism contacts are
//! 2½-D (a latch nose, a cam, a pin in a slot), and on such a profile the closest point to
//! a pin is exact and cheap: a projection on a line or a circle.
//!
//! A profile is split into features: its segments, its arcs and its convex corners (where
//! two pieces meet at an angle, or where an open profile ends). Each feature owns the
//! region of the plane whose closest profile point lies on it (a strip, a sector, a cone),
//! so that a pin near a tangent joint or a corner sees exactly one of them, and a pin
//! between two walls (a slot) sees both. One contact candidate is a feature seen from one
//! face of the profile's thickness: the two faces carry the moment of a tilting pin.

use crate::mechanics::body::Pose;
use nalgebra::{Vector2, Vector3};
use std::f64::consts::TAU;

/// Gap reported by a candidate whose feature does not face the pin: it is out of play until
/// the pin enters the feature's region. Large, but finite, so that gap interpolation over a
/// step (`integrator/impact.rs`) stays finite.
pub const OUT_OF_REACH: f64 = 1.0e6;

/// One piece of a profile path, from the end of the previous piece (or the start).
#[derive(Clone, Debug, PartialEq)]
pub enum Piece {
    Line {
        to: Vector2<f64>,
    },
    /// Circular arc about `center`, counter-clockwise in the plane's (u, v) axes when `ccw`.
    /// An arc whose end is its start is a full circle.
    Arc {
        to: Vector2<f64>,
        center: Vector2<f64>,
        ccw: bool,
    },
}

/// Where the material is: inside or outside a closed profile; left or right of an open one
/// (walking along it from its start).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Solid {
    Inside,
    Outside,
    Left,
    Right,
}

#[derive(Clone, Debug, PartialEq)]
enum Feature {
    /// `normal` points to the open side.
    Line {
        a: Vector2<f64>,
        tangent: Vector2<f64>,
        length: f64,
        normal: Vector2<f64>,
    },
    /// `side` = +1 where the open side is away from the centre (the material is inside the
    /// circle: a cam), −1 where it is towards it (a hole, a slot's end).
    Arc {
        center: Vector2<f64>,
        radius: f64,
        /// Unit vector from the centre to the arc's start.
        start: Vector2<f64>,
        /// Sweep angle (> 0) in the sense `ccw`.
        sweep: f64,
        ccw: bool,
        side: f64,
    },
    /// A convex vertex: the pin sees it where it is past the end of the incoming piece
    /// (along `t_in`) and before the start of the outgoing one (along `t_out`). At the ends
    /// of an open profile one tangent is missing and the open side's normal bounds the cone.
    Corner {
        at: Vector2<f64>,
        t_in: Option<Vector2<f64>>,
        t_out: Option<Vector2<f64>>,
        normal: Vector2<f64>,
    },
}

/// A planar outline (a profile primitive), extruded, in its body's frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Outline {
    /// Centre of the extrusion (on the profile's plane, mid-thickness), body frame.
    origin: Vector3<f64>,
    /// The plane's axes u, v and its normal n = u × v, body frame.
    axes: [Vector3<f64>; 3],
    pub half_thickness: f64,
    features: Vec<Feature>,
    /// The path as drawn: its points (arcs sampled), for drawings.
    outline: Vec<Vector2<f64>>,
    /// The path's own points: its start and each piece's end.
    vertices: Vec<Vector2<f64>>,
    pub closed: bool,
}

/// Closest point of a feature to a pin centre in the plane: signed distance of the centre
/// (> 0 on the open side), unit normal towards the open side, and the foot on the feature.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Foot {
    distance: f64,
    normal: Vector2<f64>,
    at: Vector2<f64>,
}

fn cross(a: &Vector2<f64>, b: &Vector2<f64>) -> f64 {
    a.x * b.y - a.y * b.x
}

/// The angle (> 0) an arc turns through from the radius `s` to the radius `e`, in the
/// sense `ccw`; an arc back to its start turns a full circle.
fn sweep(s: &Vector2<f64>, e: &Vector2<f64>, ccw: bool) -> f64 {
    let turn = if ccw { 1.0 } else { -1.0 };
    let sweep = (turn * cross(s, e)).atan2(s.dot(e));
    if sweep <= 1e-12 {
        sweep + TAU
    } else {
        sweep
    }
}

/// The left normal of a direction.
fn left(t: &Vector2<f64>) -> Vector2<f64> {
    Vector2::new(-t.y, t.x)
}

impl Outline {
    /// Builds a profile from its start and pieces. `axes` are the plane's in-plane axes and
    /// normal (body frame, orthonormal, right-handed) and `origin` the plane's origin. The
    /// path is closed when its last piece ends at its start. Errors name the piece (index
    /// into `pieces`) and what is wrong.
    pub fn new(
        origin: Vector3<f64>,
        axes: [Vector3<f64>; 3],
        thickness: f64,
        start: Vector2<f64>,
        pieces: &[Piece],
        solid: Solid,
    ) -> Result<Outline, (Option<usize>, String)> {
        if pieces.is_empty() {
            return Err((None, "a profile needs at least one piece".into()));
        }
        if !(thickness > 0.0 && thickness.is_finite()) {
            return Err((None, "thickness must be positive".into()));
        }
        let scale = pieces
            .iter()
            .map(|p| match p {
                Piece::Line { to } => to.norm(),
                Piece::Arc { to, center, .. } => to.norm() + center.norm(),
            })
            .fold(start.norm(), f64::max)
            .max(f64::MIN_POSITIVE);
        let tol = 1e-9 * scale;
        let end = match pieces.last() {
            Some(Piece::Line { to } | Piece::Arc { to, .. }) => *to,
            None => start,
        };
        let closed = (end - start).norm() <= tol;
        // `sign` turns the left normal of the walking direction into the open side's normal.
        let sign = match (solid, closed) {
            (Solid::Right, false) => 1.0,
            (Solid::Left, false) => -1.0,
            (Solid::Inside | Solid::Outside, true) => {
                let ccw = signed_area(start, pieces) > 0.0;
                // walking counter-clockwise, the inside is on the left
                if ccw == (solid == Solid::Outside) {
                    1.0
                } else {
                    -1.0
                }
            }
            (Solid::Inside | Solid::Outside, false) => {
                return Err((
                    None,
                    "`inside`/`outside` need a closed profile (its last piece ending at `start`); an open one takes `left` or `right`".into(),
                ))
            }
            (Solid::Left | Solid::Right, true) => {
                return Err((
                    None,
                    "a closed profile takes `solid: inside` or `outside`, not `left`/`right`"
                        .into(),
                ))
            }
        };
        let mut pieces_out = Vec::new();
        // (start tangent, end tangent) of each piece, for the corners
        let mut tangents = Vec::new();
        let mut from = start;
        let mut outline = vec![start];
        // the piece each segment of the outline belongs to
        let mut owner: Vec<usize> = Vec::new();
        for (i, p) in pieces.iter().enumerate() {
            match p {
                Piece::Line { to } => {
                    let d = to - from;
                    let length = d.norm();
                    if length <= tol {
                        return Err((Some(i), "zero-length segment".into()));
                    }
                    let tangent = d / length;
                    pieces_out.push(Feature::Line {
                        a: from,
                        tangent,
                        length,
                        normal: left(&tangent) * sign,
                    });
                    tangents.push((tangent, tangent));
                    outline.push(*to);
                    owner.push(i);
                }
                Piece::Arc { to, center, ccw } => {
                    let (r0, r1) = ((from - center).norm(), (to - center).norm());
                    if r0 <= tol {
                        return Err((Some(i), "arc centre on its start point".into()));
                    }
                    if (r0 - r1).abs() > tol {
                        return Err((
                            Some(i),
                            format!(
                                "inconsistent radius: the start is {r0} from the centre and the end {r1}"
                            ),
                        ));
                    }
                    let s = (from - center) / r0;
                    let e = (to - center) / r0;
                    let turn = if *ccw { 1.0 } else { -1.0 };
                    let sweep = sweep(&s, &e, *ccw);
                    // walking counter-clockwise the centre is on the left
                    let side = -sign * turn;
                    let tangent_at = |u: &Vector2<f64>| left(u) * turn;
                    tangents.push((tangent_at(&s), tangent_at(&e)));
                    let n = (sweep / TAU * 64.0).ceil().max(2.0) as usize;
                    for k in 1..=n {
                        let a = turn * sweep * k as f64 / n as f64;
                        let (sin, cos) = a.sin_cos();
                        outline.push(
                            center
                                + Vector2::new(cos * s.x - sin * s.y, sin * s.x + cos * s.y) * r0,
                        );
                        owner.push(i);
                    }
                    pieces_out.push(Feature::Arc {
                        center: *center,
                        radius: r0,
                        start: s,
                        sweep,
                        ccw: *ccw,
                        side,
                    });
                }
            }
            from = match p {
                Piece::Line { to } | Piece::Arc { to, .. } => *to,
            };
        }
        if let Some((i, j, at)) = crossing(&outline, &owner, closed, tol) {
            return Err((
                Some(j),
                format!(
                    "the profile crosses itself: piece {i} and piece {j} intersect near ({:.6}, {:.6}); a contact against it would be undefined",
                    at.x, at.y
                ),
            ));
        }
        // convex corners: the walk turns away from the open side
        let mut features = Vec::new();
        let n = pieces_out.len();
        let normal_at_start = |k: usize| left(&tangents[k].0) * sign;
        let normal_at_end = |k: usize| left(&tangents[k].1) * sign;
        let vertex = |k: usize| match &pieces_out[k] {
            Feature::Line { a, .. } => *a,
            Feature::Arc {
                center,
                radius,
                start,
                ..
            } => center + start * *radius,
            Feature::Corner { .. } => unreachable!(),
        };
        for k in 0..n {
            if k > 0 || closed {
                let prev = (k + n - 1) % n;
                let (t_in, t_out) = (tangents[prev].1, tangents[k].0);
                let turn = cross(&t_in, &t_out);
                // a turn away from the open side, or a reversal (the tip of a spike)
                let convex = sign * turn < -1e-9 || (turn.abs() <= 1e-9 && t_in.dot(&t_out) < 0.0);
                if convex {
                    let mid = normal_at_end(prev) + normal_at_start(k);
                    features.push(Feature::Corner {
                        at: vertex(k),
                        t_in: Some(t_in),
                        t_out: Some(t_out),
                        normal: if mid.norm() > 1e-9 {
                            mid.normalize()
                        } else {
                            t_in
                        },
                    });
                }
            } else {
                features.push(Feature::Corner {
                    at: start,
                    t_in: None,
                    t_out: Some(tangents[0].0),
                    normal: normal_at_start(0),
                });
            }
            features.push(pieces_out[k].clone());
        }
        if !closed {
            features.push(Feature::Corner {
                at: end,
                t_in: Some(tangents[n - 1].1),
                t_out: None,
                normal: normal_at_end(n - 1),
            });
        }
        let vertices = std::iter::once(start)
            .chain(pieces.iter().map(|p| match p {
                Piece::Line { to } | Piece::Arc { to, .. } => *to,
            }))
            .collect();
        Ok(Outline {
            origin,
            axes,
            half_thickness: 0.5 * thickness,
            features,
            outline,
            vertices,
            closed,
        })
    }

    /// Number of features (segments, arcs, convex corners).
    pub fn feature_count(&self) -> usize {
        self.features.len()
    }

    /// The outline's points in the body frame (arcs sampled), for drawings.
    pub fn outline(&self) -> impl Iterator<Item = Vector3<f64>> + '_ {
        self.outline
            .iter()
            .map(|p| self.origin + self.axes[0] * p.x + self.axes[1] * p.y)
    }

    /// The closest point of feature `k` to the centre `c` of a pin (plane coordinates), if
    /// `c` is in the feature's region.
    fn foot(&self, k: usize, c: &Vector2<f64>) -> Option<Foot> {
        match &self.features[k] {
            Feature::Line {
                a,
                tangent,
                length,
                normal,
            } => {
                let t = tangent.dot(&(c - a));
                (0.0..*length).contains(&t).then(|| Foot {
                    distance: normal.dot(&(c - a)),
                    normal: *normal,
                    at: a + tangent * t,
                })
            }
            Feature::Arc {
                center,
                radius,
                start,
                sweep,
                ccw,
                side,
            } => {
                let w = c - center;
                let d = w.norm();
                let turn = if *ccw { 1.0 } else { -1.0 };
                let mut phi = (turn * cross(start, &w)).atan2(start.dot(&w));
                if phi < 0.0 {
                    phi += TAU;
                }
                if d == 0.0 {
                    // the centre of a hole's arc: every point of the arc is as near; take its middle
                    let (sin, cos) = (turn * 0.5 * sweep).sin_cos();
                    let mid =
                        Vector2::new(cos * start.x - sin * start.y, sin * start.x + cos * start.y);
                    return Some(Foot {
                        distance: -side * radius,
                        normal: -mid * *side,
                        at: center + mid * *radius,
                    });
                }
                (phi < *sweep).then(|| {
                    let u = w / d;
                    Foot {
                        distance: side * (d - radius),
                        normal: u * *side,
                        at: center + u * *radius,
                    }
                })
            }
            Feature::Corner {
                at,
                t_in,
                t_out,
                normal,
            } => {
                let w = c - at;
                let past_in = t_in.map_or(normal.dot(&w) >= 0.0, |t| t.dot(&w) >= 0.0);
                let before_out = t_out.map_or(normal.dot(&w) >= 0.0, |t| t.dot(&w) < 0.0);
                (past_in && before_out).then(|| {
                    let d = w.norm();
                    Foot {
                        distance: d,
                        normal: if d > 0.0 { w / d } else { *normal },
                        at: *at,
                    }
                })
            }
        }
    }

    /// The foot of feature `k` if the pin centre `c` is in play with it: in its region and
    /// on its open side; or, where the centre has gone through the material (a pin of
    /// radius 0 pressed in), on the nearest feature or one about as near (both sides of a
    /// notch). This keeps the far side of a cam, whose region also holds the pin, out.
    fn in_play(&self, k: usize, c: &Vector2<f64>) -> Option<Foot> {
        let f = self.foot(k, c)?;
        if f.distance >= 0.0 {
            return Some(f);
        }
        let nearest = (0..self.features.len())
            .filter_map(|j| self.foot(j, c))
            .min_by(|a, b| a.distance.abs().total_cmp(&b.distance.abs()))?;
        (nearest.distance < 0.0 && -f.distance <= 2.0 * nearest.distance.abs()).then_some(f)
    }

    /// The signed distance from `c` (plane coordinates) to the profile, > 0 on the open
    /// side: the nearest of the features in play (`None` if none is).
    pub fn distance(&self, c: &Vector2<f64>) -> Option<f64> {
        (0..self.features.len())
            .filter_map(|k| self.in_play(k, c))
            .map(|f| f.distance)
            .min_by(|a, b| a.abs().total_cmp(&b.abs()))
    }

    /// Number of candidate points against a pin with `faces` contact planes.
    pub fn candidate_count(&self, faces: usize) -> usize {
        faces * self.features.len()
    }

    /// Candidate `k` of a pin against this profile (on a body at `pose`): the gap, normal
    /// (towards the pin) and points, and for an arc with the pin on its concave side the
    /// lateral curvature 1/|centre offset| with the in-plane tangent and the pin centre
    /// (world). A candidate out of play has the gap `OUT_OF_REACH`.
    pub fn contact(&self, pose: &Pose, pin: &Pin, k: usize) -> ProfileContact {
        let features = self.features.len();
        let (face, feature) = (k / features, k % features);
        let o = pose.point(&self.origin);
        let n = pose.dir(&self.axes[2]);
        let z_c = n.dot(&(pin.center - o));
        // the centre of the pin's section in contact plane `face`
        let section = match pin.axis {
            Some((axis, half_length)) => {
                let a_z = axis.dot(&n);
                if a_z.abs() < 1e-9 {
                    // lying in the plane: not a pin; its centre's section only
                    (z_c.abs() <= self.half_thickness).then_some(pin.center)
                } else {
                    let reach = half_length * a_z.abs();
                    let lo = (z_c - reach).max(-self.half_thickness);
                    let hi = (z_c + reach).min(self.half_thickness);
                    (lo <= hi).then(|| {
                        let z = if face == 0 { lo } else { hi };
                        pin.center + axis * ((z - z_c) / a_z)
                    })
                }
            }
            None => (z_c.abs() <= self.half_thickness).then_some(pin.center),
        };
        let far = ProfileContact {
            geometry: super::ContactGeometry {
                gap: OUT_OF_REACH,
                normal: n,
                point1: pin.center,
                point2: pin.center,
            },
            lateral: None,
        };
        let Some(c3) = section else { return far };
        let Some((geometry, c)) = self.circle_against(pose, &c3, pin.radius, feature) else {
            return far;
        };
        let lateral = match &self.features[feature] {
            Feature::Arc { center, side, .. } if *side < 0.0 => {
                let offset = (c - center).norm().max(1e-12);
                Some((n.cross(&geometry.normal), c3, 1.0 / offset))
            }
            _ => None,
        };
        ProfileContact { geometry, lateral }
    }

    /// A circle of `radius` centred at the inertial point `centre`, in a plane parallel to
    /// this profile's (on a body at `pose`), against feature `k`: the contact (the normal
    /// this feature's, towards the circle) and the centre in plane coordinates; `None`
    /// where the feature is not in play.
    fn circle_against(
        &self,
        pose: &Pose,
        centre: &Vector3<f64>,
        radius: f64,
        k: usize,
    ) -> Option<(super::ContactGeometry, Vector2<f64>)> {
        let o = pose.point(&self.origin);
        let [u, v, n] = self.axes.map(|a| pose.dir(&a));
        let w = centre - o;
        let c = Vector2::new(u.dot(&w), v.dot(&w));
        let f = self.in_play(k, &c)?;
        let normal = u * f.normal.x + v * f.normal.y;
        let geometry = super::ContactGeometry {
            gap: f.distance - radius,
            normal,
            point1: centre - normal * radius,
            point2: o + u * f.at.x + v * f.at.y + n * n.dot(&w),
        };
        Some((geometry, c))
    }
}

/// One profile's parts that act as pins on another profile: the points of its path
/// (radius 0: its corners, its ends and its tangent joints, where a flat between two
/// hollows ends) and its convex arcs (their circles, where the touching point lies on the
/// arc, `arc` being that feature).
#[derive(Clone, Copy, Debug)]
struct ProfilePin {
    arc: Option<usize>,
    center: Vector2<f64>,
    radius: f64,
}

impl Outline {
    fn pins(&self) -> impl Iterator<Item = ProfilePin> + '_ {
        let points = if self.closed {
            &self.vertices[..self.vertices.len() - 1]
        } else {
            &self.vertices[..]
        };
        let points = points.iter().map(|&center| ProfilePin {
            arc: None,
            center,
            radius: 0.0,
        });
        let arcs = self
            .features
            .iter()
            .enumerate()
            .filter_map(|(k, f)| match f {
                Feature::Arc {
                    center,
                    radius,
                    side,
                    ..
                } if *side > 0.0 => Some(ProfilePin {
                    arc: Some(k),
                    center: *center,
                    radius: *radius,
                }),
                _ => None,
            });
        points.chain(arcs)
    }

    /// Candidate points against another profile `a` (on body 1; this one is on body 2):
    /// per face of the two thicknesses' overlap, each pin of `a` against each feature of
    /// this profile, then each pin of this one against each feature of `a`.
    pub fn candidate_count_against(&self, a: &Outline) -> usize {
        2 * (a.pins().count() * self.features.len() + self.pins().count() * a.features.len())
    }

    /// Candidate `k` of profile `a` (on a body at `pa`, body 1) against this profile (at
    /// `pb`, body 2), in the order of `candidate_count_against`. The two planes are taken
    /// as parallel (a planar mechanism); the faces are the ends of the overlap of the two
    /// thicknesses along this profile's normal.
    pub fn contact_profile(
        &self,
        pb: &Pose,
        a: &Outline,
        pa: &Pose,
        k: usize,
    ) -> super::ContactGeometry {
        let per_face = self.candidate_count_against(a) / 2;
        let (face, k) = (k / per_face, k % per_face);
        let ob = pb.point(&self.origin);
        let nb = pb.dir(&self.axes[2]);
        let oa = pa.point(&a.origin);
        let z_a = nb.dot(&(oa - ob));
        let reach = a.half_thickness * pa.dir(&a.axes[2]).dot(&nb).abs();
        let (lo, hi) = (
            (z_a - reach).max(-self.half_thickness),
            (z_a + reach).min(self.half_thickness),
        );
        let far = super::ContactGeometry {
            gap: OUT_OF_REACH,
            normal: nb,
            point1: oa,
            point2: ob,
        };
        if lo > hi {
            return far;
        }
        let z = if face == 0 { lo } else { hi };
        let a_pins = a.pins().count() * self.features.len();
        if k < a_pins {
            let pin = a.pins().nth(k / self.features.len()).expect("pin index");
            pin_on_profile(a, pa, &pin, self, pb, k % self.features.len(), z).unwrap_or(far)
        } else {
            let k = k - a_pins;
            let pin = self.pins().nth(k / a.features.len()).expect("pin index");
            // the same with the roles swapped, seen from body 1's side
            let z_self = z - z_a; // the face, along a's normal, from a's mid-plane (parallel planes)
            let z_in_a = z_self * pa.dir(&a.axes[2]).dot(&nb).signum();
            pin_on_profile(self, pb, &pin, a, pa, k % a.features.len(), z_in_a)
                .map(|g| super::ContactGeometry {
                    gap: g.gap,
                    normal: -g.normal,
                    point1: g.point2,
                    point2: g.point1,
                })
                .unwrap_or(far)
        }
    }
}

/// Pin `pin` of profile `p` (on a body at `pp`) against feature `j` of profile `q` (at
/// `pq`), in the plane at height `z` along q's normal from q's mid-plane: the gap, q's
/// outward normal, the point on the pin and the point on q; `None` where the feature is
/// not in play or the touching point of an arc pin is off its arc.
fn pin_on_profile(
    p: &Outline,
    pp: &Pose,
    pin: &ProfilePin,
    q: &Outline,
    pq: &Pose,
    j: usize,
    z: f64,
) -> Option<super::ContactGeometry> {
    let [up, vp, np] = p.axes.map(|a| pp.dir(&a));
    let nq = pq.dir(&q.axes[2]);
    let oq = pq.point(&q.origin);
    let centre = pp.point(&p.origin) + up * pin.center.x + vp * pin.center.y;
    // onto the contact plane, along p's normal
    let along = np.dot(&nq);
    let centre = centre + np * ((z - nq.dot(&(centre - oq))) / along);
    let (g, _) = q.circle_against(pq, &centre, pin.radius, j)?;
    if let Some(arc) = pin.arc {
        // the touching point of the arc, in p's plane coordinates, must lie on the arc
        let dir = -g.normal;
        let d2 = Vector2::new(up.dot(&dir), vp.dot(&dir));
        p.foot(arc, &(pin.center + d2 * pin.radius))?;
    }
    Some(g)
}

/// A pin against a profile, in the world: a point (radius 0), a sphere, or a cylinder
/// (`axis`: unit axis and half-length) whose sections in the profile's two faces touch it.
#[derive(Clone, Copy, Debug)]
pub struct Pin {
    pub center: Vector3<f64>,
    pub radius: f64,
    pub axis: Option<(Vector3<f64>, f64)>,
}

impl Pin {
    /// The pin of a point, sphere or cylinder on a body at `pose`.
    pub fn of(shape: &super::Primitive, pose: &Pose) -> Pin {
        use super::Primitive as P;
        match shape {
            P::Point { position } => Pin {
                center: pose.point(position),
                radius: 0.0,
                axis: None,
            },
            P::Sphere { center, radius } => Pin {
                center: pose.point(center),
                radius: *radius,
                axis: None,
            },
            P::Cylinder {
                center,
                axis,
                radius,
                half_length,
            } => Pin {
                center: pose.point(center),
                radius: *radius,
                axis: Some((pose.dir(&axis.normalize()), *half_length)),
            },
            _ => {
                unreachable!("only points, spheres and cylinders meet profiles (ContactPair::new)")
            }
        }
    }
}

/// A profile candidate's geometry, with the curvature of a concave arc for the projection.
pub struct ProfileContact {
    pub geometry: super::ContactGeometry,
    /// In-plane direction across the normal, where the pin centre is, and κ.
    pub lateral: Option<(Vector3<f64>, Vector3<f64>, f64)>,
}

/// The first two pieces whose outline segments cross (pieces i < j, and the point), on
/// the outline's polyline (arcs sampled); segments that meet at a shared end do not count.
fn crossing(
    outline: &[Vector2<f64>],
    owner: &[usize],
    closed: bool,
    tol: f64,
) -> Option<(usize, usize, Vector2<f64>)> {
    let m = owner.len();
    let orient = |a: &Vector2<f64>, b: &Vector2<f64>, c: &Vector2<f64>| cross(&(b - a), &(c - a));
    for p in 0..m {
        let (a, b) = (outline[p], outline[p + 1]);
        for q in p + 2..m {
            // the last segment of a closed outline meets the first at the start
            if closed && p == 0 && q == m - 1 {
                continue;
            }
            let (c, d) = (outline[q], outline[q + 1]);
            let scale = tol * ((b - a).norm() + (d - c).norm());
            let (o1, o2) = (orient(&a, &b, &c), orient(&a, &b, &d));
            let (o3, o4) = (orient(&c, &d, &a), orient(&c, &d, &b));
            let proper = |x: f64, y: f64| (x > scale && y < -scale) || (x < -scale && y > scale);
            if proper(o1, o2) && proper(o3, o4) {
                let t = o3 / (o3 - o4);
                return Some((owner[p], owner[q], a + (b - a) * t));
            }
        }
    }
    None
}

/// Twice the signed area enclosed by a closed path (> 0 counter-clockwise), arcs included.
fn signed_area(start: Vector2<f64>, pieces: &[Piece]) -> f64 {
    let mut from = start;
    let mut area = 0.0;
    for p in pieces {
        match p {
            Piece::Line { to } => {
                area += cross(&from, to);
                from = *to;
            }
            Piece::Arc { to, center, ccw } => {
                // chord, plus the circular segment between chord and arc
                let r = (from - center).norm();
                let turn = if *ccw { 1.0 } else { -1.0 };
                let sweep = sweep(&(from - center), &(to - center), *ccw);
                area += cross(&from, to) + turn * r * r * (sweep - sweep.sin());
                from = *to;
            }
        }
    }
    area
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    fn xy() -> [Vector3<f64>; 3] {
        [Vector3::x(), Vector3::y(), Vector3::z()]
    }

    fn v(x: f64, y: f64) -> Vector2<f64> {
        Vector2::new(x, y)
    }

    /// A latch-like part (mm): a flat, a convex fillet and a flank joined tangentially, a
    /// concave notch met at corners, then two flats with right-angle corners.
    fn latch() -> (Vector2<f64>, Vec<Piece>) {
        let pieces = vec![
            Piece::Line { to: v(0.04, 0.0) },
            Piece::Arc {
                to: v(0.05, 0.01),
                center: v(0.04, 0.01),
                ccw: true,
            },
            Piece::Line { to: v(0.05, 0.03) },
            Piece::Arc {
                to: v(0.03, 0.03),
                center: v(0.04, 0.04),
                ccw: false,
            },
            Piece::Line { to: v(0.0, 0.03) },
            Piece::Line { to: v(0.0, 0.0) },
        ];
        (v(0.0, 0.0), pieces)
    }

    /// Points along each piece of a path, as functions of a parameter in [0, 1].
    fn parametrised(
        start: Vector2<f64>,
        pieces: &[Piece],
    ) -> Vec<Box<dyn Fn(f64) -> Vector2<f64>>> {
        let mut from = start;
        let mut out: Vec<Box<dyn Fn(f64) -> Vector2<f64>>> = Vec::new();
        for p in pieces {
            match *p {
                Piece::Line { to } => {
                    let a = from;
                    out.push(Box::new(move |t| a + (to - a) * t));
                    from = to;
                }
                Piece::Arc { to, center, ccw } => {
                    let (s, e) = (from - center, to - center);
                    let a0 = s.y.atan2(s.x);
                    let turn = if ccw { 1.0 } else { -1.0 };
                    let mut sweep = (turn * cross(&s, &e)).atan2(s.dot(&e));
                    if sweep <= 1e-12 {
                        sweep += TAU;
                    }
                    let r = s.norm();
                    out.push(Box::new(move |t| {
                        let a = a0 + turn * sweep * t;
                        center + v(a.cos(), a.sin()) * r
                    }));
                    from = to;
                }
            }
        }
        out
    }

    /// Distance from `c` to the path by brute force: 1e5 samples, then a golden-section
    /// search around the best sample of each piece.
    fn sampled_distance(c: &Vector2<f64>, pieces: &[Box<dyn Fn(f64) -> Vector2<f64>>]) -> f64 {
        let n = 100_000 / pieces.len();
        pieces
            .iter()
            .map(|f| sampled_minimum(|t| (f(t) - c).norm(), n))
            .fold(f64::MAX, f64::min)
    }

    /// The smallest value of `d` on [0, 1]: the best of `n` + 1 samples, refined by a
    /// golden-section search between its neighbours, and the two ends.
    fn sampled_minimum(d: impl Fn(f64) -> f64, n: usize) -> f64 {
        let i = (0..=n)
            .min_by(|&a, &b| d(a as f64 / n as f64).total_cmp(&d(b as f64 / n as f64)))
            .unwrap();
        let (mut lo, mut hi) = (
            (i as f64 - 1.0).max(0.0) / n as f64,
            (i as f64 + 1.0).min(n as f64) / n as f64,
        );
        let g = 0.5 * (5f64.sqrt() - 1.0);
        while hi - lo > 1e-15 {
            let (a, b) = (hi - g * (hi - lo), lo + g * (hi - lo));
            if d(a) < d(b) {
                hi = b;
            } else {
                lo = a;
            }
        }
        d(0.5 * (lo + hi)).min(d(0.0)).min(d(1.0))
    }

    /// Whether `c` is inside the closed path (even–odd rule on a fine polygon).
    fn inside(c: &Vector2<f64>, pieces: &[Box<dyn Fn(f64) -> Vector2<f64>>]) -> bool {
        let poly: Vec<Vector2<f64>> = pieces
            .iter()
            .flat_map(|f| (0..2000).map(move |i| f(i as f64 / 2000.0)))
            .collect();
        let mut inside = false;
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            if (a.y > c.y) != (b.y > c.y) && c.x < a.x + (c.y - a.y) / (b.y - a.y) * (b.x - a.x) {
                inside = !inside;
            }
        }
        inside
    }

    /// A deterministic spread of points (a fixed linear congruential sequence).
    fn points(n: usize, lo: Vector2<f64>, hi: Vector2<f64>) -> Vec<Vector2<f64>> {
        let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| v(lo.x + (hi.x - lo.x) * next(), lo.y + (hi.y - lo.y) * next()))
            .collect()
    }

    /// The signed distance matches brute-force sampling to 1e-12 m around and inside the
    /// latch, at points spread over it and at points chosen near each tangent joint, each
    /// corner and inside the notch; its sign is the side of the material.
    #[test]
    fn distance_matches_brute_force_on_segments_arcs_joints_and_corners() {
        let (start, pieces) = latch();
        let profile =
            Outline::new(Vector3::zeros(), xy(), 0.01, start, &pieces, Solid::Inside).unwrap();
        // the right-angle corners, and the notch's two ends: four convex corners
        let corners = profile
            .features
            .iter()
            .filter(|f| matches!(f, Feature::Corner { .. }))
            .count();
        assert_eq!(corners, 4);
        let path = parametrised(start, &pieces);
        let mut queries = points(400, v(-0.01, -0.01), v(0.06, 0.045));
        // near the tangent joints (0.04, 0) and (0.05, 0.01), the corners and the notch
        for (x, y) in [
            (0.04, -0.002),
            (0.0400001, -0.003),
            (0.0399999, 0.001),
            (0.052, 0.01),
            (0.052, 0.0100001),
            (0.052, 0.0099999),
            (-0.001, -0.002),
            (-0.003, 0.031),
            (0.051, 0.031),
            (0.03, 0.0305),
            (0.04, 0.035),
            (0.04, 0.0401),
            (0.0401, 0.028),
            (0.02, 0.015),
        ] {
            queries.push(v(x, y));
        }
        let mut worst: f64 = 0.0;
        for c in &queries {
            let d = profile
                .distance(c)
                .expect("every point has a nearest feature");
            let exact = sampled_distance(c, &path);
            worst = worst.max((d.abs() - exact).abs());
            assert!(
                (d.abs() - exact).abs() < 1e-12,
                "at {c:?}: {d} against {exact}"
            );
            if exact > 1e-4 {
                assert_eq!(d < 0.0, inside(c, &path), "side at {c:?}: {d}");
            }
        }
        assert!(worst < 1e-12);
    }

    /// Each candidate's gap falls at the rate of its normal (the gap's gradient), and the
    /// feet and normals agree across a tangent joint: a pin rolling over it sees one
    /// continuous surface.
    #[test]
    fn normals_are_gap_gradients_and_continuous_across_tangent_joints() {
        let (start, pieces) = latch();
        let profile =
            Outline::new(Vector3::zeros(), xy(), 0.01, start, &pieces, Solid::Inside).unwrap();
        let dist = |c: Vector2<f64>| profile.distance(&c).unwrap();
        let eps = 1e-7;
        for c in points(200, v(-0.01, -0.01), v(0.06, 0.045)) {
            let k = (0..profile.features.len())
                .filter_map(|k| profile.in_play(k, &c).map(|f| (k, f)))
                .min_by(|a, b| a.1.distance.abs().total_cmp(&b.1.distance.abs()))
                .unwrap();
            let grad = v(
                dist(c + v(eps, 0.0)) - dist(c - v(eps, 0.0)),
                dist(c + v(0.0, eps)) - dist(c - v(0.0, eps)),
            ) / (2.0 * eps);
            assert!(
                (grad - k.1.normal).norm() < 1e-5,
                "at {c:?}: {grad:?} vs {:?}",
                k.1.normal
            );
        }
        // across the joint of the flat and the fillet at (0.04, 0), 1 mm below
        let feet: Vec<Foot> = [0.04 - 1e-9, 0.04 + 1e-9]
            .iter()
            .map(|&x| {
                let c = v(x, -0.001);
                (0..profile.features.len())
                    .find_map(|k| profile.in_play(k, &c))
                    .unwrap()
            })
            .collect();
        assert!((feet[0].normal - feet[1].normal).norm() < 1e-6);
        assert!((feet[0].at - feet[1].at).norm() < 1e-8);
        assert!((feet[0].distance - 0.001).abs() < 1e-15);
    }

    /// A pin outside a round cam sees the cam's one arc; the far side of a long cam, whose
    /// strip also holds the pin, stays out of play.
    #[test]
    fn the_far_side_of_a_cam_is_out_of_play() {
        // a stadium: two flats 0.1 long, two half circles of radius 0.01
        let pieces = vec![
            Piece::Line { to: v(0.1, -0.01) },
            Piece::Arc {
                to: v(0.1, 0.01),
                center: v(0.1, 0.0),
                ccw: true,
            },
            Piece::Line { to: v(0.0, 0.01) },
            Piece::Arc {
                to: v(0.0, -0.01),
                center: v(0.0, 0.0),
                ccw: true,
            },
        ];
        let p = Outline::new(
            Vector3::zeros(),
            xy(),
            0.01,
            v(0.0, -0.01),
            &pieces,
            Solid::Inside,
        )
        .unwrap();
        let above = v(0.05, 0.03);
        let in_play: Vec<f64> = (0..p.feature_count())
            .filter_map(|k| p.in_play(k, &above))
            .map(|f| f.distance)
            .collect();
        assert_eq!(in_play.len(), 1);
        assert!((in_play[0] - 0.02).abs() < 1e-15, "{in_play:?}");
        // the same shape as a hole: a pin inside sees both flats (a slot)
        let hole = Outline::new(
            Vector3::zeros(),
            xy(),
            0.01,
            v(0.0, -0.01),
            &pieces,
            Solid::Outside,
        )
        .unwrap();
        let pin = v(0.05, 0.004);
        let mut seen: Vec<f64> = (0..hole.feature_count())
            .filter_map(|k| hole.in_play(k, &pin))
            .map(|f| f.distance)
            .collect();
        seen.sort_by(f64::total_cmp);
        assert!(
            (seen[0] - 0.006).abs() < 1e-15 && (seen[1] - 0.014).abs() < 1e-15,
            "{seen:?}"
        );
        assert_eq!(seen.len(), 2);
    }

    /// A cylinder pin touches with its sections in the two faces of the profile; tilted,
    /// the two sections sit at different depths, and a pin beside the plate touches nothing.
    #[test]
    fn a_tilted_pin_touches_with_both_faces() {
        let pieces = vec![Piece::Line { to: v(1.0, 0.0) }];
        // a floor along u, material below, in the body's xz plane (normal −y... use u = x, v = z)
        let axes = [Vector3::x(), Vector3::z(), -Vector3::y()];
        let wall = Outline::new(
            Vector3::zeros(),
            axes,
            0.02,
            v(-1.0, 0.0),
            &pieces,
            Solid::Right,
        )
        .unwrap();
        let tilt = 0.01;
        let pose = Pose::identity();
        let pin = Pin {
            center: Vector3::new(0.0, 0.0, 0.05),
            radius: 0.05,
            axis: Some((
                UnitQuaternion::from_euler_angles(tilt, 0.0, 0.0) * Vector3::y(),
                0.1,
            )),
        };
        let count = wall.candidate_count(2);
        let gaps: Vec<f64> = (0..count)
            .map(|k| wall.contact(&pose, &pin, k).geometry.gap)
            .filter(|&g| g < OUT_OF_REACH)
            .collect();
        assert_eq!(gaps.len(), 2);
        // the axis turns about x: at y = ±0.01 the section centre moves by ∓0.01 tan(tilt) in z
        let expect = 0.01 * tilt.tan();
        assert!(
            (gaps[0].abs() - expect).abs() < 1e-15 && (gaps[0] + gaps[1]).abs() < 1e-15,
            "{gaps:?}"
        );
        let beside = Pin {
            center: Vector3::new(0.0, 0.5, 0.05),
            ..pin
        };
        assert!((0..count).all(|k| wall.contact(&pose, &beside, k).geometry.gap == OUT_OF_REACH));
    }

    /// Bad paths are refused with the piece that is wrong.
    #[test]
    fn bad_paths_name_the_piece() {
        let line = |x: f64, y: f64| Piece::Line { to: v(x, y) };
        let err = |start: Vector2<f64>, pieces: &[Piece], solid: Solid| {
            Outline::new(Vector3::zeros(), xy(), 0.01, start, pieces, solid).unwrap_err()
        };
        let e = err(
            v(0.0, 0.0),
            &[line(1.0, 0.0), line(1.0, 0.0), line(0.0, 1.0)],
            Solid::Left,
        );
        assert_eq!(e.0, Some(1));
        assert!(e.1.contains("zero-length"), "{}", e.1);
        let arc = Piece::Arc {
            to: v(2.0, 0.0),
            center: v(1.2, 0.5),
            ccw: true,
        };
        let e = err(v(0.0, 0.0), &[arc], Solid::Left);
        assert_eq!(e.0, Some(0));
        assert!(e.1.contains("inconsistent radius"), "{}", e.1);
        let e = err(v(0.0, 0.0), &[line(1.0, 0.0)], Solid::Inside);
        assert!(e.1.contains("closed"), "{}", e.1);
    }
    /// A tooth: a flank, a round tip (a convex arc), a flank back and a base.
    fn tooth() -> (Vector2<f64>, Vec<Piece>) {
        let r = 0.004;
        let pieces = vec![
            Piece::Line {
                to: v(0.01 - r, 0.02),
            },
            Piece::Arc {
                to: v(0.01 + r, 0.02),
                center: v(0.01, 0.02),
                ccw: false,
            },
            Piece::Line { to: v(0.02, 0.0) },
            Piece::Line { to: v(0.0, 0.0) },
        ];
        (v(0.0, 0.0), pieces)
    }

    /// Profile against profile: the smallest gap over the candidates is the distance
    /// between the two outlines, by sampling each piece of one (2000 points, then golden
    /// section) against the other's exact distance, to 1e-12 m over in-plane poses that
    /// keep them apart, with the tooth turned and placed around the latch.
    #[test]
    fn profile_against_profile_matches_the_outline_distance() {
        use crate::mechanics::contact::{ContactPair, Primitive};
        let (ls, lp) = latch();
        let (ts, tp) = tooth();
        let latch = Outline::new(Vector3::zeros(), xy(), 0.01, ls, &lp, Solid::Inside).unwrap();
        let tooth = Outline::new(Vector3::zeros(), xy(), 0.01, ts, &tp, Solid::Inside).unwrap();
        let pair = ContactPair::new(
            "latch",
            Some(0),
            Primitive::Profile(Box::new(tooth.clone())),
            Some(1),
            Primitive::Profile(Box::new(latch.clone())),
            0.0,
            0.0,
        )
        .unwrap();
        let tooth_pieces = parametrised(ts, &tp);
        let mut checked = 0;
        for (i, p) in points(300, v(-0.04, -0.04), v(0.09, 0.08))
            .iter()
            .enumerate()
        {
            let angle = i as f64 * 0.7;
            let pa = Pose {
                x: Vector3::new(p.x, p.y, 0.0),
                p: UnitQuaternion::from_euler_angles(0.0, 0.0, angle),
            };
            let pb = Pose {
                x: Vector3::new(0.001, -0.002, 0.0),
                p: UnitQuaternion::from_euler_angles(0.0, 0.0, 0.3),
            };
            // the tooth's outline in the latch's plane coordinates
            let in_latch = |q: Vector2<f64>| {
                let w = pb.local(&pa.point(&Vector3::new(q.x, q.y, 0.0)));
                v(w.x, w.y)
            };
            let dist = |q: Vector2<f64>| latch.distance(&in_latch(q)).unwrap();
            let exact = tooth_pieces
                .iter()
                .map(|f| sampled_minimum(|t| dist(f(t)), 2000))
                .fold(f64::MAX, f64::min);
            // apart only: the latch's exact distance then bounds the outlines' distance
            let apart = tooth_pieces
                .iter()
                .all(|f| (0..=200).all(|k| dist(f(k as f64 / 200.0)) > 0.0))
                && (0..=400).all(|k| {
                    let q = pb.point(&Vector3::new(0.02 + 0.0 * k as f64, 0.015, 0.0));
                    let _ = q;
                    true
                });
            if !apart || exact > 0.02 {
                continue;
            }
            let gap = (0..pair.candidates())
                .map(|k| pair.evaluate(k, &[pa, pb]).gap())
                .fold(f64::MAX, f64::min);
            assert!(
                (gap - exact).abs() < 1e-12,
                "pose {i}: {gap} against {exact}"
            );
            checked += 1;
        }
        println!("{checked} poses checked");
        assert!(checked > 50, "{checked} poses checked");
    }
}
