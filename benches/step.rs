//! Time per step of the Moreau–Jean integrator on the bundled scenes:
//! - bouncing ball (Newton–Euler sphere, 10 s at h = 1 ms: flight, impacts, Zeno, rest),
//! - 4-corner box sliding then sticking on a 20° incline with friction (3 s),
//! - free asymmetric rigid body (gyroscopic Newton loop, 10 s).
//!
//! - pendulum and driven four-bar with ideal joints under each scheme (plain Moreau–Jean,
//!   combined projection, direct projection): the price of the projection.
//!
//! - pendulum and slider-crank with the joint ideal versus with clearance.
//!
//! - a toggle clamp (tests/data/toggle-clamp.yaml) closing, and closing then locked on its
//!   stop for 340 ms: a contact on a part its joints lock has a singular block.
//!
//! Criterion reports time per element = per step. Run: `cargo bench --bench step`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use mc_study::integrator::Scheme;
use mc_study::scene::Scene;
use std::hint::black_box;
use std::path::Path;

fn scene(name: &str) -> Scene {
    Scene::load(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("studies")
            .join(name)
            .join("scene.yaml"),
    )
    .unwrap()
}

fn bench_scene(c: &mut Criterion, label: &str, name: &str, duration: f64) {
    bench_with(c, "step", label, scene(name), duration);
}

fn bench_with(c: &mut Criterion, group: &str, label: &str, s: Scene, duration: f64) {
    let steps = (duration / s.params.h).round() as u64;
    let mut g = c.benchmark_group(group);
    g.throughput(Throughput::Elements(steps));
    g.sample_size(20);
    g.bench_function(label, |b| {
        b.iter_batched(
            || s.simulation().unwrap(),
            |mut sim| {
                sim.run_until(duration, |_, _| {}).unwrap();
                black_box(sim.state.t)
            },
            criterion::BatchSize::LargeInput,
        )
    });
    g.finish();
}

fn steps(c: &mut Criterion) {
    bench_scene(c, "bouncing_ball", "bouncing-ball", 10.0);
    bench_scene(c, "box_4_corners_friction", "incline-block", 3.0);
    bench_scene(c, "free_rigid_body", "free-body", 10.0);
}

fn schemes(c: &mut Criterion) {
    for name in ["pendulum", "four-bar"] {
        for scheme in [
            Scheme::MoreauJean,
            Scheme::CombinedProjection,
            Scheme::DirectProjection,
        ] {
            let mut s = scene(name);
            s.params.scheme = scheme;
            bench_with(c, "scheme", &format!("{name}/{}", scheme.name()), s, 2.0);
        }
    }
}

/// The price of modelling a clearance: the same scene with the joint ideal (`revolute`)
/// and with clearance (`revolute-clearance`).
fn clearance(c: &mut Criterion) {
    for (name, duration) in [("pendulum-clearance", 0.5), ("slider-crank-clearance", 0.2)] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("studies")
            .join(name)
            .join("scene.yaml");
        let text = std::fs::read_to_string(&path).unwrap();
        let ideal = Scene::from_yaml(
            &text.replace("type: revolute-clearance", "type: revolute"),
            name,
        )
        .unwrap();
        bench_with(c, "clearance", &format!("{name}/ideal"), ideal, duration);
        bench_with(
            c,
            "clearance",
            &format!("{name}/clearance"),
            scene(name),
            duration,
        );
    }
}

/// The toggle clamp's first 40 ms (closing, no rigid contact) and its whole 400 ms (then
/// at rest on its stop): the second's time per step is mostly the rest's.
fn locked(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/toggle-clamp.yaml");
    let clamp = Scene::load(&path).unwrap();
    bench_with(c, "locked", "toggle_clamp_closing", clamp.clone(), 0.04);
    bench_with(c, "locked", "toggle_clamp_then_at_rest", clamp, 0.4);
}

criterion_group!(benches, steps, schemes, clearance, locked);
criterion_main!(benches);
