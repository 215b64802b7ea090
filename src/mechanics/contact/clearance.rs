//! Revolute joint with radial and axial clearance (docs/clearance-joint.md): a bore of
//! radius R_B = R_J + c and length L_B on body B, a journal of radius R_J on body J, and
//! flanges on the journal at both ends of the bore. It is a set of unilateral frictional
//! contacts, no compliance:
//! - two ring–cylinder contacts: each end ring of the bore against the journal cylinder,
//!   closest point by Newton on the ring angle from the axis/ring-plane intersection;
//! - m rim points per flange against the bore's end faces (axial play);
//! - guards: further points of each ring, spaced evenly around it from the closest point,
//!   against the journal. They stay far from contact while one step moves the journal by
//!   less than its clearance, so they change nothing then. When a step would carry the
//!   journal across its bore (a large step, or a clearance of nanometres) the integrator
//!   activates the guard the journal is heading for: the velocity problem then keeps the
//!   journal inside the hexagon they circumscribe, instead of letting it slide along the
//!   closest point's tangent plane and projecting it back from far outside the ring.

use super::{point_row, BodyFrame, ContactGeometry, ContactPoint, Lateral};
use crate::math::any_orthogonal;
use crate::math::blocks::vector6_at;
use crate::mechanics::body::BodyRef;
use crate::mechanics::body::{pose_of, Pose, Twist};
use nalgebra::Vector3;

#[derive(Clone, Debug, PartialEq)]
pub struct ClearanceJoint {
    pub name: String,
    /// Body carrying the bore (the rings and the end faces).
    pub bore_body: BodyRef,
    /// Body carrying the journal (pin) and its flanges.
    pub journal_body: BodyRef,
    /// Bore centre (mid-length) and unit axis, in the bore body's frame.
    pub bore_center: Vector3<f64>,
    pub bore_axis: Vector3<f64>,
    pub bore_length: f64,
    /// A point on the journal axis (centred in the bore at assembly) and the unit axis, in
    /// the journal body's frame.
    pub journal_point: Vector3<f64>,
    pub journal_axis: Vector3<f64>,
    pub journal_radius: f64,
    /// Radial clearance c = R_B − R_J (> 0).
    pub clearance: f64,
    /// Total free axial travel between the flanges and the bore faces (> 0).
    pub axial_play: f64,
    /// Radius of the flange rim points (contact annulus outer radius).
    pub flange_radius: f64,
    /// Rim points per flange side (≥ 3).
    pub rim_points: usize,
    pub mu: f64,
    pub e: f64,
}

/// Points per ring, the closest point included: the guards sit every 60°, so the
/// hexagon they circumscribe leaves the journal at most c (1/cos 30° − 1) = 0.15 c beyond
/// its ring for the projection to remove.
const RING_POINTS: usize = 6;

/// Newton iterations on the ring angle (1–3 are enough from the intersection guess; the
/// loop stops at `ANGLE_STEP`).
const NEWTON_STEPS: usize = 5;

/// The smallest Newton step on the ring angle that is taken (rad): it moves a ring point of
/// radius r by 1e-12 r, and the angle it leaves out is of order the step squared.
const ANGLE_STEP: f64 = 1e-12;

impl ClearanceJoint {
    pub fn bore_radius(&self) -> f64 {
        self.journal_radius + self.clearance
    }

    /// 2 rings + 2 × rim points + 2 × guards.
    pub fn candidates(&self) -> usize {
        2 + 2 * self.rim_points + 2 * (RING_POINTS - 1)
    }

    /// Whether candidate `k` is a guard: a ring point that is not the closest one. The
    /// integrator activates guards from the velocity step only and never projects them
    /// (g = 0 at a guard and at the closest point of the same ring cannot both hold).
    pub fn is_guard(&self, k: usize) -> bool {
        k >= 2 + 2 * self.rim_points
    }

    /// Side (−1 or +1) and index 1…5 of guard candidate `k`.
    pub fn guard(&self, k: usize) -> (f64, usize) {
        let j = k - 2 - 2 * self.rim_points;
        let side = if j < RING_POINTS - 1 { -1.0 } else { 1.0 };
        (side, j % (RING_POINTS - 1) + 1)
    }

    /// The bore and journal frames in the world at `poses`.
    fn frames(&self, poses: &[Pose]) -> Frames {
        let (pb, pj) = (
            pose_of(self.bore_body, poses),
            pose_of(self.journal_body, poses),
        );
        Frames {
            a_b: pb.dir(&self.bore_axis),
            a_j: pj.dir(&self.journal_axis),
            c_b: pb.point(&self.bore_center),
            p_j: pj.point(&self.journal_point),
            pb: BodyFrame::new(pb),
            pj: BodyFrame::new(pj),
        }
    }

    /// The joint at `poses`: its frames and each ring with its closest-point angle (found
    /// once and shared by the ring's point and its guards).
    pub fn place(&self, poses: &[Pose]) -> Placed {
        let f = self.frames(poses);
        let ring = |side: f64| {
            let centre = f.c_b + f.a_b * (side * 0.5 * self.bore_length);
            let ring = Ring::new(centre, f.a_b, self.bore_radius());
            let at = ring.closest_angle(&f.p_j, &f.a_j);
            (ring, at)
        };
        Placed {
            rings: [ring(-1.0), ring(1.0)],
            frames: f,
        }
    }

    /// Candidate `k`: 0 and 1 are the − and + rings; then the rim points of the − flange,
    /// then of the + flange; then the guards of the − ring, then of the + ring.
    pub fn evaluate(&self, k: usize, poses: &[Pose]) -> ContactPoint {
        self.point(k, &self.place(poses))
    }

    /// Candidate `k` of the joint `placed` (as `evaluate` numbers them).
    pub fn point(&self, k: usize, placed: &Placed) -> ContactPoint {
        let mut point = ContactPoint::placeholder();
        self.write_point(k, placed, &mut point);
        point
    }

    /// `point` written over `slot`, where it is built: a point of 520 bytes built aside and
    /// copied into a list is read back while its stores are still in flight. (Inlined, it
    /// was built aside again.)
    #[inline(never)]
    pub fn write_point(&self, k: usize, placed: &Placed, slot: &mut ContactPoint) {
        let Frames {
            pb,
            pj,
            a_b,
            a_j,
            c_b,
            p_j,
        } = placed.frames;
        if k < 2 || self.is_guard(k) {
            let (ring, at, guard) = self.ring_point(k, placed);
            let g = ring.point_against_journal(at, &p_j, &a_j, self.journal_radius);
            let t2 = g.normal.cross(&a_j);
            // a guard is open when it acts: frictionless, on the linearised gap
            let lateral = (!guard).then(|| self.lateral(&g, &a_j, &pb, &pj));
            slot.renew(
                g,
                self.bore_body,
                &pb,
                self.journal_body,
                &pj,
                Some((a_j, t2)),
                if guard { 0.0 } else { self.mu },
                if guard { 0.0 } else { self.e },
            );
            slot.gap_law = guard;
            slot.lateral = lateral;
        } else {
            let j = k - 2;
            let (side, idx) = if j < self.rim_points {
                (-1.0, j)
            } else {
                (1.0, j - self.rim_points)
            };
            // flange face on the journal, just outside the bore face by half the axial play
            let offset = side * 0.5 * (self.bore_length + self.axial_play);
            let b1 = any_orthogonal(&self.journal_axis);
            let b2 = self.journal_axis.cross(&b1);
            let (sin, cos) = rim_turn(idx, self.rim_points);
            let local = self.journal_point
                + self.journal_axis * offset
                + (b1 * cos + b2 * sin) * self.flange_radius;
            let x = pj.pose.point(&local);
            let nu = a_b * side;
            let face = c_b + a_b * (side * 0.5 * self.bore_length);
            let gap = (x - face).dot(&nu);
            let g = ContactGeometry {
                gap,
                normal: nu,
                point1: x,
                point2: x - nu * gap,
            };
            slot.renew(
                g,
                self.journal_body,
                &pj,
                self.bore_body,
                &pb,
                None,
                self.mu,
                self.e,
            );
        }
    }

    /// The gap of ring point `k` (a ring's closest point or a guard) of the joint `placed`
    /// written over `slot`'s, the rest of `slot` left as it is: bit for bit the gap that
    /// `write_point` gives, for the cost of the distance alone.
    pub fn write_gap(&self, k: usize, placed: &Placed, slot: &mut ContactPoint) {
        let (ring, at, _) = self.ring_point(k, placed);
        let Frames { a_j, p_j, .. } = placed.frames;
        slot.geometry.gap = ring.axis_offset(at, &p_j, &a_j).2.norm() - self.journal_radius;
    }

    /// Ring point `k` (0 or 1, or a guard) of the joint `placed`: its ring, the cosine and
    /// sine of its angle, and whether it is a guard.
    fn ring_point<'a>(&self, k: usize, placed: &'a Placed) -> (&'a Ring, (f64, f64), bool) {
        let (side, offset) = match k {
            0 => (-1.0, 0),
            1 => (1.0, 0),
            _ => self.guard(k),
        };
        let (ring, (cos, sin)) = &placed.rings[usize::from(side > 0.0)];
        // the closest point's angle turned by offset/RING_POINTS of a turn
        let (turn_cos, turn_sin) = ring_turns()[offset];
        let at = (
            cos * turn_cos - sin * turn_sin,
            sin * turn_cos + cos * turn_sin,
        );
        (ring, at, offset != 0)
    }

    /// The ring contact's curvature across its normal: the journal axis's foot (the
    /// surface point moved in by R_J) displaced along n × a_J, κ = 1/|e| with |e| = R_B − the
    /// ring's distance to the axis (floored at c/1000: the gap is a cone at |e| = 0, but
    /// there it is c, far from any projection).
    fn lateral(
        &self,
        g: &ContactGeometry,
        a_j: &Vector3<f64>,
        pb: &BodyFrame,
        pj: &BodyFrame,
    ) -> Lateral {
        let foot = g.point2 - g.normal * self.journal_radius;
        let dir = g.normal.cross(a_j);
        let offset = (self.clearance - g.gap).max(1e-3 * self.clearance);
        Lateral {
            g1: -point_row(&dir, pb, &foot),
            g2: point_row(&dir, pj, &foot),
            kappa: 1.0 / offset,
        }
    }

    /// Upper bounds on the normal speed |u_N| of every point of the − and + rings against
    /// the journal, for the twists `v` at `poses`: |w| + |Ω_B − Ω_J| R_B, with w the
    /// relative velocity of the two bodies' material points at the ring's centre and Ω
    /// their angular velocities (a ring point is R_B from the centre). They let a step pass
    /// over the guards that it cannot carry the journal across without forming their
    /// speeds. The two rings share the bodies' angular velocities.
    pub fn ring_speed_bounds(&self, poses: &[Pose], v: &[f64]) -> [f64; 2] {
        let bore = pose_of(self.bore_body, poses);
        // a body's twist and its angular velocity in the world
        let motion = |r: BodyRef| {
            r.map(|i| {
                let tw = vector6_at(v, 6 * i);
                (i, tw, poses[i].p * tw.fixed_rows::<3>(3))
            })
        };
        let (b, j) = (motion(self.bore_body), motion(self.journal_body));
        let omega = |m: Option<(usize, Twist, Vector3<f64>)>| m.map_or(Vector3::zeros(), |m| m.2);
        let spin = (omega(b) - omega(j)).norm() * self.bore_radius();
        [-1.0, 1.0].map(|side| {
            let centre =
                bore.point(&(self.bore_center + self.bore_axis * (side * 0.5 * self.bore_length)));
            // the velocity of a body's material point at the centre
            let at_centre = |m: Option<(usize, Twist, Vector3<f64>)>| {
                m.map_or(Vector3::zeros(), |(i, tw, omega)| {
                    tw.fixed_rows::<3>(0) + omega.cross(&(centre - poses[i].x))
                })
            };
            (at_centre(b) - at_centre(j)).norm() + spin
        })
    }

    /// The bore's centre (mid-length, on its axis) in the world at `poses`.
    pub fn centre(&self, poses: &[Pose]) -> Vector3<f64> {
        self.frames(poses).c_b
    }

    /// The journal's offset from the bore axis at the bore's mid-plane (world): where the
    /// journal axis crosses the plane through the bore centre normal to the bore axis,
    /// less the centre. Its length is the eccentricity that the clearance bounds.
    pub fn eccentricity(&self, poses: &[Pose]) -> Vector3<f64> {
        let Frames {
            a_b, a_j, c_b, p_j, ..
        } = self.frames(poses);
        let along = a_b.dot(&a_j);
        let crossing = if along.abs() > 1e-12 {
            p_j + a_j * (a_b.dot(&(c_b - p_j)) / along)
        } else {
            p_j
        };
        let e = crossing - c_b;
        e - a_b * a_b.dot(&e)
    }

    /// An error when the journal has left the bore: its axis misses a ring by more than the
    /// bore radius, or an end ring falls outside the journal's length (flange to flange).
    pub fn check(&self, poses: &[Pose]) -> Result<(), String> {
        let Frames {
            a_b, a_j, c_b, p_j, ..
        } = self.frames(poses);
        let reach = 0.5 * (self.bore_length + self.axial_play);
        for side in [-1.0, 1.0] {
            let ring = c_b + a_b * (side * 0.5 * self.bore_length);
            let axial = (ring - p_j).dot(&a_j);
            let radial = ((ring - p_j) - a_j * axial).norm();
            if axial.abs() > reach + self.axial_play || radial > self.bore_radius() {
                return Err(format!(
                    "the journal of clearance joint `{}` left its bore (axial {:.3e} m, radial {:.3e} m)",
                    self.name, axial, radial
                ));
            }
        }
        Ok(())
    }
}

/// A clearance joint's frames in the world: the body poses (bore, journal), the bore axis
/// and centre, the journal axis and point.
#[derive(Clone, Copy)]
struct Frames {
    pb: BodyFrame,
    pj: BodyFrame,
    a_b: Vector3<f64>,
    a_j: Vector3<f64>,
    c_b: Vector3<f64>,
    p_j: Vector3<f64>,
}

/// A clearance joint placed at given poses: its frames, and each ring (−, +) with the
/// cosine and sine of its closest-point angle.
pub struct Placed {
    frames: Frames,
    rings: [(Ring, (f64, f64)); 2],
}

/// Clearance joints placed at one set of poses, by joint index: kept where an evaluation
/// places them, so that a later evaluation at the same poses need not place them again.
#[derive(Default)]
pub struct Placements {
    placed: Vec<Option<Placed>>,
}

impl Placements {
    /// Forgets every placement (the poses changed).
    pub fn clear(&mut self) {
        self.placed.iter_mut().for_each(|p| *p = None);
    }

    /// Joint `joint`'s placement, if it has been kept.
    pub fn get(&self, joint: usize) -> Option<&Placed> {
        self.placed.get(joint)?.as_ref()
    }

    /// Keeps `placed` as joint `joint`'s placement.
    pub fn keep(&mut self, joint: usize, placed: Placed) -> &Placed {
        if self.placed.len() <= joint {
            self.placed.resize_with(joint + 1, || None);
        }
        self.placed[joint].insert(placed)
    }
}

/// (sin, cos) of `k`/`n` of a turn: a flange's rim point k of n. Tabulated once for the
/// counts up to `TABULATED_RIM`, so that a rim point costs no sine and cosine.
fn rim_turn(k: usize, n: usize) -> (f64, f64) {
    let turn = |k: usize, n: usize| (2.0 * std::f64::consts::PI * k as f64 / n as f64).sin_cos();
    static TURNS: std::sync::OnceLock<Vec<Vec<(f64, f64)>>> = std::sync::OnceLock::new();
    match TURNS
        .get_or_init(|| {
            (0..=TABULATED_RIM)
                .map(|n| (0..n).map(|k| turn(k, n)).collect())
                .collect()
        })
        .get(n)
    {
        Some(turns) => turns[k],
        None => turn(k, n),
    }
}

/// Rim point counts up to this one have their turns tabulated.
const TABULATED_RIM: usize = 64;

/// (cos, sin) of k/RING_POINTS of a turn, k = 0…RING_POINTS − 1: the guards' angles from the
/// closest point, turned by products instead of a sine and cosine per guard.
fn ring_turns() -> &'static [(f64, f64); RING_POINTS] {
    static TURNS: std::sync::OnceLock<[(f64, f64); RING_POINTS]> = std::sync::OnceLock::new();
    TURNS.get_or_init(|| {
        std::array::from_fn(|k| {
            let (sin, cos) = (2.0 * std::f64::consts::PI * k as f64 / RING_POINTS as f64).sin_cos();
            (cos, sin)
        })
    })
}

/// A bore's end ring: centre, unit normal (the bore axis), radius, and a basis of its plane.
struct Ring {
    c: Vector3<f64>,
    a: Vector3<f64>,
    r: f64,
    b1: Vector3<f64>,
    b2: Vector3<f64>,
}

impl Ring {
    fn new(c: Vector3<f64>, a: Vector3<f64>, r: f64) -> Self {
        let b1 = any_orthogonal(&a);
        let b2 = a.cross(&b1);
        Ring { c, a, r, b1, b2 }
    }

    /// The ring point at the angle whose cosine and sine are `at`.
    fn point(&self, (cos, sin): (f64, f64)) -> Vector3<f64> {
        self.c + (self.b1 * cos + self.b2 * sin) * self.r
    }

    /// Cosine and sine of the angle of the ring point closest to the axis (`p`, unit
    /// `aj`): from where the axis crosses the ring plane, refined by Newton on f'(φ) = 0
    /// with f(φ) = ‖(P(φ) − p) × aj‖², accepted only where f'' > 0. The angle is kept as
    /// its cosine and sine, each Newton step δ = f'/f'' applied as the rotation by atan δ
    /// (exact, normalised): the same root, reached as fast (atan δ = δ − δ³/3), without a
    /// sine, cosine or arctangent per joint and step. The rotation by atan(f'/f'') is
    /// formed from f' and f'' directly (one square root and one division: the roots and
    /// divisions, not the products, are what this costs). The axis is taken into the
    /// ring's frame (b1, b2, a) once, so that each iteration works on scalars: P(φ) − p is
    /// (d1 + r cos φ, d2 + r sin φ, d3) there. A step below `ANGLE_STEP` is not taken: f'
    /// is rounded to about 1e-16 r² against f'' ≈ r e (e the journal's offset), so at a
    /// clearance of micrometres the steps below it are rounding noise, which the loop
    /// would chase to its last iteration.
    fn closest_angle(&self, p: &Vector3<f64>, aj: &Vector3<f64>) -> (f64, f64) {
        let r = self.r;
        let frame = |v: &Vector3<f64>| (v.dot(&self.b1), v.dot(&self.b2), v.dot(&self.a));
        let (d1, d2, d3) = frame(&(self.c - p));
        let (a1, a2, a3) = frame(aj);
        // where the axis crosses the ring plane, from the ring's centre
        let (ex, ey) = if a3.abs() > 1e-12 {
            let t = d3 / a3;
            (a1 * t - d1, a2 * t - d2)
        } else {
            (-d1, -d2)
        };
        let norm2 = ex * ex + ey * ey;
        let (mut cs, mut sn) = if norm2 > 0.0 {
            let k = 1.0 / norm2.sqrt();
            (ex * k, ey * k)
        } else {
            (1.0, 0.0)
        };
        for _ in 0..NEWTON_STEPS {
            // w = P − p and its derivatives w1, w2 in φ, each against aj; then f'/2 and
            // f''/2 (w1·w1 + w·w2 = −r (d1 cos φ + d2 sin φ))
            let wa = a1 * (d1 + r * cs) + a2 * (d2 + r * sn) + a3 * d3;
            let w1a = r * (a2 * cs - a1 * sn);
            let w2a = -r * (a1 * cs + a2 * sn);
            let f1 = r * (d2 * cs - d1 * sn) - wa * w1a;
            let f2 = -r * (d1 * cs + d2 * sn) - w1a * w1a - wa * w2a;
            if f2 <= 0.0 || f1.abs() <= ANGLE_STEP * f2 {
                break;
            }
            // φ ← φ − atan(f1/f2): cos and sin of atan(f1/f2) are f2/h and f1/h
            let k = 1.0 / (f1 * f1 + f2 * f2).sqrt();
            (cs, sn) = ((cs * f2 + sn * f1) * k, (sn * f2 - cs * f1) * k);
        }
        (cs, sn)
    }

    /// The ring point at the angle whose cosine and sine are `at`, its foot on the axis
    /// (`p`, unit `aj`), and its offset from there (the ring point less the foot).
    fn axis_offset(
        &self,
        at: (f64, f64),
        p: &Vector3<f64>,
        aj: &Vector3<f64>,
    ) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        let ring_point = self.point(at);
        let foot = p + aj * (ring_point - p).dot(aj);
        (ring_point, foot, ring_point - foot)
    }

    /// The ring point at the angle whose cosine and sine are `at`, against the cylinder
    /// (`p`, `aj`, radius `rj`): the normal points from the cylinder surface towards the
    /// ring point, gap = distance − rj.
    fn point_against_journal(
        &self,
        at: (f64, f64),
        p: &Vector3<f64>,
        aj: &Vector3<f64>,
        rj: f64,
    ) -> ContactGeometry {
        let (ring_point, foot, d) = self.axis_offset(at, p, aj);
        let dist = d.norm();
        let normal = if dist > 0.0 {
            d / dist
        } else {
            any_orthogonal(aj)
        };
        ContactGeometry {
            gap: dist - rj,
            normal,
            point1: ring_point,
            point2: foot + normal * rj,
        }
    }
}

/// Closest point between the ring (centre `c`, unit normal `a`, radius `r`) and the
/// cylinder of axis (`p`, unit `aj`) and radius `rj`. Body 1 carries the ring: the normal
/// points from the cylinder surface towards the ring point, gap = distance − rj.
pub fn ring_journal(
    c: &Vector3<f64>,
    a: &Vector3<f64>,
    r: f64,
    p: &Vector3<f64>,
    aj: &Vector3<f64>,
    rj: f64,
) -> ContactGeometry {
    let ring = Ring::new(*c, *a, r);
    ring.point_against_journal(ring.closest_angle(p, aj), p, aj, rj)
}
