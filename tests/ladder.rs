//! A frictionless ladder sliding down a wall: a rod with a ball at each end, one on the
//! floor and one against the wall, both faces fixed boxes. The contacts' normals never
//! turn, but the levers from the rod's centre to its contact points do, as the rod turns
//! while its ends slide. With both contacts closed the ladder has one degree of freedom,
//! its angle θ to the floor, and since its centre moves on a circle of radius L/2 about
//! the corner, (m L²/4 + I) θ'' = −m g (L/2) cos θ: a pendulum, integrated here by RK4.
//! The combined-projection step must follow it to second order in h.

mod common;

use mc_study::scene::Scene;

const G: f64 = 9.81;
/// Distance between the balls' centres (m), the balls' radius (m), the rod's mass (kg) and
/// its cross-section's side (m).
const L: f64 = 1.0;
const R: f64 = 0.01;
const M: f64 = 1.0;
const SIDE: f64 = 0.02;
/// The start angle to the floor, released from rest: the top leaves the wall once sin θ
/// falls to about 2/3 of sin θ₀ (θ ≈ 35°), well after `T`.
const THETA0_DEG: f64 = 60.0;
const T: f64 = 0.25;

/// The ladder's angle to the floor at `T`, simulated at step `h`.
fn simulated_angle(h: f64) -> f64 {
    let th = THETA0_DEG.to_radians();
    let (cx, cy) = (R + 0.5 * L * th.cos(), R + 0.5 * L * th.sin());
    let yaml = format!(
        r#"
duration: {T} s
gravity: [0, -{G}, 0]
integrator: {{ h: {h}, scheme: combined-projection, solver: {{ tolerance: 1e-12 }}, projection: {{ tolerance: 1e-13 }} }}
bodies:
  - name: rod
    mass: {M} kg
    shape: {{ box: {{ size: [{L}, {SIDE}, {SIDE}] }} }}
    orientation: {{ axis: [0, 0, 1], angle: -{THETA0_DEG} deg }}
    position: [{cx}, {cy}, 0]
contacts:
  - name: foot
    body: rod
    shape: {{ sphere: {{ radius: {R}, center: [{half}, 0, 0] }} }}
    against: ground
    against_shape: {{ box: {{ size: [4, 1, 1], center: [1.5, -0.5, 0] }} }}
    mu: 0
  - name: top
    body: rod
    shape: {{ sphere: {{ radius: {R}, center: [-{half}, 0, 0] }} }}
    against: ground
    against_shape: {{ box: {{ size: [1, 4, 1], center: [-0.5, 1.5, 0] }} }}
    mu: 0
"#,
        half = 0.5 * L
    );
    let scene = Scene::from_yaml(&yaml, "ladder").unwrap_or_else(|e| panic!("{e}"));
    let mut sim = common::simulation(scene);
    sim.run_until(T, |_, _| {})
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(
        sim.stats.max_penetration < 1e-9,
        "h = {h}: penetration {:.2e} m",
        sim.stats.max_penetration
    );
    // the centre is at height R + (L/2) sin θ while both balls touch
    let y = sim.state.poses[0].x.y;
    ((y - R) / (0.5 * L)).asin()
}

/// θ(T) of (m L²/4 + I) θ'' = −m g (L/2) cos θ from rest at θ₀, by RK4 at 1 µs.
fn exact_angle() -> f64 {
    let inertia = M * (L * L + SIDE * SIDE) / 12.0;
    let k = M * G * 0.5 * L / (M * L * L / 4.0 + inertia);
    let steps = (T / 1e-6).round() as usize;
    common::rk4_angle_from_rest(THETA0_DEG.to_radians(), T, steps, |th| -k * th.cos())
}

/// The angle's error falls as h² (measured: 5.2e-6, 1.3e-6 and 3.2e-7 rad at 4, 2 and
/// 1 ms; it fell as h, from 5.3e-4 to 1.3e-4 rad, when the contacts kept their start rows
/// because their normals do not turn), and at 1 ms it is below 1e-5 rad.
#[test]
fn a_ladder_sliding_down_a_wall_converges_to_second_order() {
    let exact = exact_angle();
    // the ladder falls 14° by T, with both ends on their faces
    assert!((THETA0_DEG.to_radians() - exact).to_degrees() > 10.0);
    let hs = [4e-3, 2e-3, 1e-3];
    let errors: Vec<f64> = hs
        .iter()
        .map(|&h| (simulated_angle(h) - exact).abs())
        .collect();
    let slope = common::loglog_slope(&hs, &errors);
    assert!(
        slope > 1.7,
        "errors {errors:?} at h = {hs:?}: order {slope:.2}, not 2"
    );
    assert!(errors[2] < 1e-5, "error {:.3e} rad at h = 1 ms", errors[2]);
}
