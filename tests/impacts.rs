//! Impacts located within their steps (`integrator: { locate_impacts: true }`): a box that
//! flies flat onto a plane, against its closed-form motion.

mod common;

use mc_study::scene::Scene;

const V0: f64 = 1.0;
const MASS: f64 = 2.0;

/// A 2 kg box, no gravity, flying flat at 1 m/s onto the plane z = 0 with restitution `e`;
/// its four lower corners touch at t* = `gap` / 1 m/s, at fraction 0.3 of a 1 ms step.
fn flat_box(e: f64, locate: bool, gap: f64) -> mc_study::integrator::Simulation {
    let yaml = format!(
        "
duration: 0.05 s
gravity: [0, 0, 0]
integrator: {{ h: 1 ms, locate_impacts: {locate} }}
bodies:
  - name: box
    mass: {MASS} kg
    shape: {{ box: {{ size: [0.2, 0.1, 0.05] }} }}
    position: [0, 0, {z}]
    velocity: [0, 0, -{V0}]
contacts:
  - name: floor
    body: box
    shape: {{ box: {{ size: [0.2, 0.1, 0.05] }} }}
    against: ground
    against_shape: {{ plane: {{ point: [0, 0, 0], normal: [0, 0, 1] }} }}
    mu: 0.3
    e: {e}
",
        z = 0.025 + gap
    );
    let scene = Scene::from_yaml(&yaml, "impacts").unwrap_or_else(|e| panic!("{e}"));
    common::simulation(scene)
}

/// Height of the box's centre at time t: down at V0 until t*, then up at e V0.
fn exact_z(e: f64, gap: f64, t: f64) -> f64 {
    let t_star = gap / V0;
    if t < t_star {
        0.025 + gap - V0 * t
    } else {
        0.025 + e * V0 * (t - t_star)
    }
}

/// Located, the impact is exact (to 1e-6 of the part of the step before it): the box leaves
/// at e V0 from the instant it touches, flat
/// (its four corners take the impact together), and the step's impulse is m (1 + e) V0.
/// Unlocated, the θ-rule moves the box over the impact's step with the mean of the two
/// velocities: it is h (s − ½)(1 + e) V0 off, 0.3 mm here, for good.
#[test]
fn a_located_impact_leaves_the_box_where_the_closed_form_motion_has_it() {
    for e in [0.0, 0.5, 1.0] {
        for gap in [0.0123, 0.0128, 0.01295] {
            let mut sim = flat_box(e, true, gap);
            let mut impulse = 0.0;
            sim.run_until(0.03, |s, _| {
                impulse += s.impulses().iter().map(|p| p.x).sum::<f64>();
            })
            .unwrap();
            let z = sim.state.poses[0].x.z;
            let err = (z - exact_z(e, gap, sim.state.t)).abs();
            // the part before the impact ends 1e-6 of itself short of the contact: the box
            // is 1e-6 s h (1 + e) V0 ≤ 1.5e-9 m off
            assert!(
                err < 2e-9,
                "e = {e}, t* = {gap} s: z = {z}, exact {}, |Δ| = {err:.2e}",
                exact_z(e, gap, sim.state.t)
            );
            assert!(
                (sim.state.v[2] - e * V0).abs() < 1e-10,
                "e = {e}: v_z = {}",
                sim.state.v[2]
            );
            let spin = sim.state.v.fixed_rows::<3>(3).norm();
            // one corner alone would turn it at about V0 / 0.1 m; 1e-8 is the solver's
            // round-off on four redundant corners
            assert!(spin < 1e-8, "e = {e}: the box turns at {spin} rad/s");
            assert!(
                (impulse - MASS * (1.0 + e) * V0).abs() < 1e-9,
                "e = {e}: total impulse {impulse}, m(1 + e)V0 = {}",
                MASS * (1.0 + e) * V0
            );
            assert_eq!(sim.stats.impact_splits, 1, "e = {e}: one step split");

            let mut plain = flat_box(e, false, gap);
            plain.run_until(0.03, |_, _| {}).unwrap();
            let z = plain.state.poses[0].x.z;
            let s = (gap % 1e-3) / 1e-3;
            let lag = 1e-3 * (s - 0.5).abs() * (1.0 + e) * V0;
            let err = (z - exact_z(e, gap, plain.state.t)).abs();
            assert!(
                e == 0.0 || err > 0.5 * lag,
                "e = {e}, s = {s}: unlocated |Δ| = {err:.2e}, expected about {lag:.2e}"
            );
        }
    }
}

/// The bouncing ball (e = 0.9, from 0.9 m) under the combined scheme: between its first two
/// impacts its energy above the resting height is e² m g g0. Located, the impact falls where
/// the secant through the step's parabola puts it, at most g h²/8 above the ground, which
/// costs at most (1 − e²) m g · g h²/8 of energy. Unlocated, the impact reflects the velocity
/// at the step's start, not at the impact: an error of first order, erratic with where the
/// impact falls in its step.
#[test]
fn a_located_bounce_keeps_the_restitution_energy_to_second_order() {
    let (e, gap0, g, r) = (0.9, 0.9, 9.81, 0.1);
    let energy_error = |h: f64, locate: bool| {
        let mut scene = common::bundled("bouncing-ball");
        scene.params.h = h;
        scene.params.scheme = mc_study::integrator::Scheme::CombinedProjection;
        scene.params.locate_impacts = locate;
        let mut sim = common::simulation(scene);
        sim.run_until(0.8, |_, _| {}).unwrap();
        let above = sim.energy() - g * r;
        (above - e * e * g * gap0).abs() / (g * gap0)
    };
    for h in [4e-3, 2e-3, 1e-3, 5e-4] {
        let located = energy_error(h, true);
        let bound = (1.0 - e * e) * g * h * h / 8.0 / gap0;
        assert!(
            located <= bound,
            "h = {h}: relative energy error {located:.3e} > {bound:.3e}"
        );
        let plain = energy_error(h, false);
        assert!(
            plain > 100.0 * located,
            "h = {h}: unlocated {plain:.3e}, located {located:.3e}"
        );
    }
}
