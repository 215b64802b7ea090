//! Drawings of a mechanism projected on a plane (SVG, one panel per snapshot): each body as
//! the box of its inertia, its contact shapes, the bores and journals of its clearance
//! joints, and the frame's own shapes. Written by hand: a drawing in millimetres is a few
//! polygons and circles, which a plotting library would only wrap.

use crate::mechanics::body::pose_of;
use crate::mechanics::contact::Primitive;
use crate::mechanics::{Model, Pose};
use nalgebra::{Matrix3, Vector2, Vector3};
use std::fmt::Write;

/// The projection plane: two world axes (right, up).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum View {
    Xy,
    Xz,
    Yz,
}

impl View {
    pub fn parse(s: &str) -> Option<View> {
        match s {
            "xy" => Some(View::Xy),
            "xz" => Some(View::Xz),
            "yz" => Some(View::Yz),
            _ => None,
        }
    }

    fn project(self, p: &Vector3<f64>) -> Vector2<f64> {
        match self {
            View::Xy => Vector2::new(p.x, p.y),
            View::Xz => Vector2::new(p.x, p.z),
            View::Yz => Vector2::new(p.y, p.z),
        }
    }
}

/// The configuration of the mechanism at one time.
pub struct Snapshot {
    pub t: f64,
    pub poses: Vec<Pose>,
}

enum Item {
    Polygon(Vec<Vector2<f64>>, &'static str),
    /// An open path (an open profile).
    Polyline(Vec<Vector2<f64>>, &'static str),
    Circle(Vector2<f64>, f64, &'static str),
    Label(Vector2<f64>, String),
}

/// Side lengths of the uniform box with the body's principal moments (its `shape` when the
/// scene gave a box): a² = 6 (I_yy + I_zz − I_xx) / m and cyclically.
fn inertia_box(mass: f64, inertia: &Matrix3<f64>) -> Vector3<f64> {
    let d = inertia.diagonal();
    let side = |a: f64, b: f64, c: f64| (6.0 * (b + c - a) / mass).max(0.0).sqrt();
    Vector3::new(
        side(d.x, d.y, d.z),
        side(d.y, d.z, d.x),
        side(d.z, d.x, d.y),
    )
}

/// Convex hull (monotone chain) of projected points.
fn hull(mut pts: Vec<Vector2<f64>>) -> Vec<Vector2<f64>> {
    pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    pts.dedup_by(|a, b| (*a - *b).norm() < 1e-15);
    if pts.len() < 3 {
        return pts;
    }
    let cross = |o: &Vector2<f64>, a: &Vector2<f64>, b: &Vector2<f64>| {
        (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x)
    };
    let mut out: Vec<Vector2<f64>> = Vec::new();
    for pass in 0..2 {
        let start = out.len();
        let iter: Box<dyn Iterator<Item = &Vector2<f64>>> = if pass == 0 {
            Box::new(pts.iter())
        } else {
            Box::new(pts.iter().rev())
        };
        for p in iter {
            while out.len() >= start + 2
                && cross(&out[out.len() - 2], &out[out.len() - 1], p) <= 0.0
            {
                out.pop();
            }
            out.push(*p);
        }
        out.pop();
    }
    out
}

fn box_outline(
    view: View,
    pose: &Pose,
    center: &Vector3<f64>,
    rotation: &nalgebra::UnitQuaternion<f64>,
    half: &Vector3<f64>,
) -> Vec<Vector2<f64>> {
    let corners = (0..8)
        .map(|k| {
            let s = |bit: usize| if k & bit != 0 { 1.0 } else { -1.0 };
            let local =
                center + rotation * Vector3::new(s(1) * half.x, s(2) * half.y, s(4) * half.z);
            view.project(&pose.point(&local))
        })
        .collect();
    hull(corners)
}

fn shape_items(
    view: View,
    pose: &Pose,
    shape: &Primitive,
    style: &'static str,
    out: &mut Vec<Item>,
) {
    match shape {
        Primitive::Sphere { center, radius } => out.push(Item::Circle(
            view.project(&pose.point(center)),
            *radius,
            style,
        )),
        Primitive::Box {
            center,
            rotation,
            half_extents,
        } => out.push(Item::Polygon(
            box_outline(view, pose, center, rotation, half_extents),
            style,
        )),
        Primitive::Capsule {
            center,
            axis,
            radius,
            half_length,
        }
        | Primitive::Cylinder {
            center,
            axis,
            radius,
            half_length,
        } => {
            for s in [-1.0, 1.0] {
                let end = center + axis.normalize() * (s * half_length);
                out.push(Item::Circle(
                    view.project(&pose.point(&end)),
                    *radius,
                    style,
                ));
            }
        }
        Primitive::Cone {
            center,
            axis,
            radius,
            half_length,
        } => {
            // the base circle, and the apex as a point
            for (s, r) in [(-1.0, *radius), (1.0, 2e-4)] {
                let end = center + axis.normalize() * (s * half_length);
                out.push(Item::Circle(view.project(&pose.point(&end)), r, style));
            }
        }
        Primitive::Point { position } => out.push(Item::Circle(
            view.project(&pose.point(position)),
            2e-4,
            style,
        )),
        Primitive::Profile(profile) => {
            let points = profile
                .outline()
                .map(|p| view.project(&pose.point(&p)))
                .collect();
            out.push(if profile.closed {
                Item::Polygon(points, style)
            } else {
                Item::Polyline(points, style)
            });
        }
        Primitive::Convex(c) => out.push(Item::Polygon(
            hull(
                c.vertices
                    .iter()
                    .map(|v| view.project(&pose.point(v)))
                    .collect(),
            ),
            style,
        )),
        Primitive::Mesh(m) => {
            for t in &m.triangles {
                let corners = t.iter().map(|&i| view.project(&pose.point(&m.vertices[i])));
                out.push(Item::Polygon(corners.collect(), style));
            }
        }
        // an unbounded half-space has no outline worth drawing in a mechanism view
        Primitive::Plane { .. } => {}
    }
}

fn items(model: &Model, poses: &[Pose], view: View) -> Vec<Item> {
    let mut out = Vec::new();
    for (i, b) in model.bodies.iter().enumerate() {
        let half = inertia_box(b.mass, &b.inertia) / 2.0;
        out.push(Item::Polygon(
            box_outline(
                view,
                &poses[i],
                &Vector3::zeros(),
                &nalgebra::UnitQuaternion::identity(),
                &half,
            ),
            "body",
        ));
    }
    for c in &model.contacts {
        shape_items(view, pose_of(c.body1, poses), &c.shape1, "shape", &mut out);
        shape_items(view, pose_of(c.body2, poses), &c.shape2, "shape", &mut out);
    }
    for j in &model.clearance_joints {
        let bore = pose_of(j.bore_body, poses).point(&j.bore_center);
        let journal = pose_of(j.journal_body, poses).point(&j.journal_point);
        out.push(Item::Circle(view.project(&bore), j.bore_radius(), "bore"));
        out.push(Item::Circle(
            view.project(&journal),
            j.journal_radius,
            "journal",
        ));
        out.push(Item::Label(view.project(&bore), j.name.clone()));
    }
    for j in &model.joints {
        let p = pose_of(j.a, poses).point(&j.anchor_a);
        out.push(Item::Circle(view.project(&p), 3e-4, "journal"));
    }
    for (i, b) in model.bodies.iter().enumerate() {
        out.push(Item::Label(view.project(&poses[i].x), b.name.clone()));
    }
    out
}

/// An SVG drawing of `model` at each snapshot, side by side, in millimetres.
pub fn svg(model: &Model, snapshots: &[Snapshot], view: View, title: &str) -> String {
    let panels: Vec<Vec<Item>> = snapshots
        .iter()
        .map(|s| items(model, &s.poses, view))
        .collect();
    // one common frame for every panel: the bounding box of everything drawn
    let (mut lo, mut hi) = (Vector2::repeat(f64::MAX), Vector2::repeat(f64::MIN));
    for it in panels.iter().flatten() {
        let mut grow = |p: Vector2<f64>, r: f64| {
            lo = lo.inf(&(p - Vector2::repeat(r)));
            hi = hi.sup(&(p + Vector2::repeat(r)));
        };
        match it {
            Item::Polygon(pts, _) | Item::Polyline(pts, _) => {
                pts.iter().for_each(|p| grow(*p, 0.0))
            }
            Item::Circle(c, r, _) => grow(*c, *r),
            Item::Label(p, _) => grow(*p, 0.0),
        }
    }
    if lo.x > hi.x {
        (lo, hi) = (Vector2::zeros(), Vector2::repeat(1e-3));
    }
    let mm = 1e3;
    let margin = 0.08 * (hi - lo).max() * mm;
    let (w, h) = (
        (hi.x - lo.x) * mm + 2.0 * margin,
        (hi.y - lo.y) * mm + 2.0 * margin,
    );
    let gap = margin;
    let header = 0.09 * h;
    let total_w = w * panels.len() as f64 + gap * (panels.len().saturating_sub(1)) as f64;
    let font = 0.035 * h;
    let stroke = 0.004 * h;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {total_w:.3} {:.3}" width="{:.0}" height="{:.0}" font-family="sans-serif">"#,
        h + header,
        total_w * 10.0,
        (h + header) * 10.0
    );
    let _ = writeln!(
        s,
        r#"<style>.body{{fill:#cfe0f5;stroke:#2b4c7e;stroke-width:{stroke:.4}}} .shape{{fill:#f2c14e;fill-opacity:0.8;stroke:#7a5c00;stroke-width:{:.4}}} .bore{{fill:none;stroke:#444;stroke-width:{:.4}}} .journal{{fill:#555}} text{{font-size:{font:.3}px;fill:#111}}</style>"#,
        stroke * 0.6,
        stroke * 0.6
    );
    let _ = writeln!(
        s,
        r#"<rect width="{total_w:.3}" height="{:.3}" fill="white"/>"#,
        h + header
    );
    for (k, (panel, snap)) in panels.iter().zip(snapshots).enumerate() {
        let x0 = k as f64 * (w + gap);
        let map = |p: &Vector2<f64>| {
            (
                x0 + margin + (p.x - lo.x) * mm,
                header + margin + (hi.y - p.y) * mm,
            )
        };
        let _ = writeln!(
            s,
            r#"<text x="{:.3}" y="{:.3}" font-size="{:.3}">{title} — t = {:.3} ms</text>"#,
            x0 + margin,
            header * 0.7,
            font * 1.3,
            snap.t * 1e3
        );
        let _ = writeln!(
            s,
            r##"<rect x="{x0:.3}" y="{header:.3}" width="{w:.3}" height="{h:.3}" fill="none" stroke="#bbb" stroke-width="{stroke:.4}"/>"##
        );
        for it in panel {
            match it {
                Item::Polygon(pts, class) | Item::Polyline(pts, class) => {
                    let points: Vec<String> = pts
                        .iter()
                        .map(|p| {
                            let (x, y) = map(p);
                            format!("{x:.4},{y:.4}")
                        })
                        .collect();
                    let element = match it {
                        Item::Polygon(..) => "polygon",
                        _ => r#"polyline fill="none""#,
                    };
                    let _ = writeln!(
                        s,
                        r#"<{element} class="{class}" points="{}"/>"#,
                        points.join(" ")
                    );
                }
                Item::Circle(c, r, class) => {
                    let (x, y) = map(c);
                    let _ = writeln!(
                        s,
                        r#"<circle class="{class}" cx="{x:.4}" cy="{y:.4}" r="{:.4}"/>"#,
                        r * mm
                    );
                }
                Item::Label(p, text) => {
                    let (x, y) = map(p);
                    let _ = writeln!(
                        s,
                        r#"<text x="{:.3}" y="{:.3}">{}</text>"#,
                        x + 0.4 * font,
                        y - 0.4 * font,
                        escape(text)
                    );
                }
            }
        }
    }
    // scale bar: 5 mm
    let _ = writeln!(
        s,
        r##"<line x1="{:.3}" y1="{:.3}" x2="{:.3}" y2="{:.3}" stroke="#000" stroke-width="{:.4}"/><text x="{:.3}" y="{:.3}">5 mm</text>"##,
        margin,
        header + h - 0.4 * margin,
        margin + 5.0,
        header + h - 0.4 * margin,
        stroke * 1.5,
        margin + 5.5,
        header + h - 0.3 * margin
    );
    s.push_str("</svg>\n");
    s
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inertia_box_recovers_the_box_sides() {
        let (m, a, b, c): (f64, f64, f64, f64) = (2.0, 0.3, 0.2, 0.1);
        let i = Matrix3::from_diagonal(&Vector3::new(
            m * (b * b + c * c) / 12.0,
            m * (a * a + c * c) / 12.0,
            m * (a * a + b * b) / 12.0,
        ));
        let s = inertia_box(m, &i);
        assert!((s - Vector3::new(a, b, c)).norm() < 1e-14, "{s:?}");
    }

    #[test]
    fn hull_of_a_square_with_an_inner_point() {
        let pts = vec![
            Vector2::new(0.0, 0.0),
            Vector2::new(1.0, 0.0),
            Vector2::new(0.5, 0.5),
            Vector2::new(1.0, 1.0),
            Vector2::new(0.0, 1.0),
        ];
        let h = hull(pts);
        assert_eq!(h.len(), 4);
        assert!(!h.contains(&Vector2::new(0.5, 0.5)));
    }
}
