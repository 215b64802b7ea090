//! Cost of evaluating every candidate of a contact pair (closest points, frame and
//! Jacobian blocks) for each pair type, against the analytic sphere–box, and the time per
//! step of a scene that uses a profile (`studies/cam-follower`).
//! Run: `cargo bench --bench geometry`.

use criterion::{criterion_group, criterion_main, Criterion};
use mc_study::mechanics::contact::convex::ConvexPart;
use mc_study::mechanics::contact::mesh::MeshPart;
use mc_study::mechanics::contact::profile::{Outline, Piece, Solid};
use mc_study::mechanics::{ContactPair, Pose, Primitive};
use mc_study::scene::Scene;
use nalgebra::{UnitQuaternion, Vector2, Vector3};
use std::hint::black_box;
use std::path::Path;

/// A latch-like profile: a flat, a fillet, a flank, a concave notch and two flats (6
/// pieces, 4 convex corners: 10 features).
fn latch() -> Primitive {
    let v = Vector2::new;
    let pieces = [
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
    let axes = [Vector3::x(), Vector3::y(), Vector3::z()];
    Primitive::Profile(Box::new(
        Outline::new(
            Vector3::zeros(),
            axes,
            0.01,
            v(0.0, 0.0),
            &pieces,
            Solid::Inside,
        )
        .unwrap(),
    ))
}

/// A box's corners as a convex part.
fn convex_box() -> Primitive {
    let corners: Vec<Vector3<f64>> = (0..8)
        .map(|k| {
            let s = |bit: usize, e: f64| if k & bit != 0 { e } else { -e };
            Vector3::new(s(1, 0.02), s(2, 0.015), s(4, 0.005))
        })
        .collect();
    Primitive::Convex(Box::new(ConvexPart::new(&corners, true).unwrap()))
}

/// A floor of 20 × 20 squares (800 triangles) at z = 0.
fn mesh_floor() -> Primitive {
    let n = 21;
    let vertices: Vec<Vector3<f64>> = (0..n * n)
        .map(|k| {
            Vector3::new(
                0.01 * (k % n) as f64 - 0.1,
                0.01 * (k / n) as f64 - 0.1,
                0.0,
            )
        })
        .collect();
    let mut triangles = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let v = |i: usize, j: usize| i + n * j;
            triangles.push([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
            triangles.push([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
        }
    }
    Primitive::Mesh(Box::new(MeshPart::new(vertices, triangles).unwrap()))
}

fn evaluations(c: &mut Criterion) {
    let sphere = Primitive::Sphere {
        center: Vector3::zeros(),
        radius: 0.005,
    };
    let cylinder = Primitive::Cylinder {
        center: Vector3::zeros(),
        axis: Vector3::z(),
        radius: 0.005,
        half_length: 0.01,
    };
    let capsule = Primitive::Capsule {
        center: Vector3::zeros(),
        axis: Vector3::z(),
        radius: 0.005,
        half_length: 0.01,
    };
    let cone = Primitive::Cone {
        center: Vector3::zeros(),
        axis: Vector3::z(),
        radius: 0.005,
        half_length: 0.01,
    };
    let boxed = Primitive::Box {
        center: Vector3::zeros(),
        rotation: UnitQuaternion::identity(),
        half_extents: Vector3::new(0.02, 0.015, 0.005),
    };
    let plane = Primitive::Plane {
        point: Vector3::zeros(),
        normal: Vector3::z(),
    };
    let poses = [
        Pose {
            x: Vector3::new(0.045, 0.036, 0.001),
            p: UnitQuaternion::from_euler_angles(0.01, -0.02, 0.3),
        },
        Pose {
            x: Vector3::new(0.002, -0.001, 0.0),
            p: UnitQuaternion::from_euler_angles(0.0, 0.0, 0.1),
        },
    ];
    let pairs = [
        ("sphere-box", sphere.clone(), boxed),
        ("sphere-plane", sphere.clone(), plane.clone()),
        ("sphere-profile", sphere.clone(), latch()),
        ("cylinder-profile", cylinder.clone(), latch()),
        ("profile-profile", latch(), latch()),
        ("convex-plane", convex_box(), plane.clone()),
        ("sphere-convex", sphere.clone(), convex_box()),
        ("convex-convex", convex_box(), convex_box()),
        ("capsule-convex", capsule.clone(), convex_box()),
        ("cylinder-plane", cylinder.clone(), plane.clone()),
        ("cylinder-convex", cylinder.clone(), convex_box()),
        ("cone-plane", cone.clone(), plane.clone()),
        ("cone-convex", cone.clone(), convex_box()),
        ("cylinder-mesh", cylinder, mesh_floor()),
        ("sphere-mesh", sphere.clone(), mesh_floor()),
        ("convex-mesh", convex_box(), mesh_floor()),
    ];
    let mut g = c.benchmark_group("contact evaluation (all candidates of the pair)");
    for (name, s1, s2) in pairs {
        let pair = ContactPair::new(name, Some(0), s1, Some(1), s2, 0.2, 0.0).unwrap();
        let n = pair.candidates();
        g.bench_function(format!("{name} ({n} candidates)"), |b| {
            b.iter(|| {
                let mut gap = f64::MAX;
                for k in 0..n {
                    gap = gap.min(pair.evaluate(k, black_box(&poses)).gap());
                }
                black_box(gap)
            })
        });
    }
    g.finish();
}

/// 100 steps of a bundled cam scene once its roller rides the cam: the cam follower (a
/// roller on a profile, a prismatic guide) and the cam rocker (the same pair, a pivot with
/// clearance, a spring).
fn cam_steps(c: &mut Criterion) {
    for (study, ride, what) in [
        ("cam-follower", 0.1, "roller on the cam, 2 candidates"),
        ("cam-rocker", 0.02, "roller on the cam, clearance pivot"),
    ] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("studies")
            .join(study)
            .join("scene.yaml");
        let scene = Scene::load(&path).unwrap();
        let mut g = c.benchmark_group(study);
        g.sample_size(10);
        g.bench_function(format!("100 steps ({what})"), |b| {
            b.iter_batched(
                || {
                    let mut sim = scene.simulation().unwrap();
                    // past the drop: the roller rides the cam
                    sim.run_until(ride, |_, _| {}).unwrap();
                    sim
                },
                |mut sim| {
                    for _ in 0..100 {
                        sim.step().unwrap();
                    }
                    black_box(sim.state.t)
                },
                criterion::BatchSize::LargeInput,
            )
        });
        g.finish();
    }
}

criterion_group!(benches, evaluations, cam_steps);
criterion_main!(benches);
