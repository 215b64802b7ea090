//! Ideal joints and the projected schemes: compound pendulum against its period and an RK4
//! reference, joint drift with and without projection, the bouncing ball without
//! penetration, and a closed-loop driven four-bar.

mod common;

use common::{bundled, loglog_slope, simulation};
use mc_study::integrator::{Scheme, Simulation};
use nalgebra::{UnitQuaternion, Vector3};

const G: f64 = 9.81;

/// The bundled pendulum released at angle `theta0` from the downward vertical.
fn pendulum(theta0: f64, scheme: Scheme, h: f64) -> Simulation {
    let mut scene = bundled("pendulum");
    // pivot at the origin, joint axis y; the bar's body x axis points from the pivot to its centre
    let alpha = std::f64::consts::FRAC_PI_2 - theta0;
    let body = &mut scene.model.bodies[0];
    body.pose.p = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), alpha);
    body.pose.x = body.pose.p * Vector3::new(0.5, 0.0, 0.0);
    let poses: Vec<_> = scene.model.bodies.iter().map(|b| b.pose).collect();
    let j = &scene.model.joints[0];
    scene.model.joints[0] = mc_study::mechanics::joint::Joint::from_world(
        "pivot",
        j.kind,
        None,
        Some(0),
        Vector3::zeros(),
        Vector3::y(),
        &poses,
        None,
    );
    scene.params.scheme = scheme;
    scene.params.h = h;
    simulation(scene)
}

/// Angle of the bar from the downward vertical (positive towards +x).
fn angle(sim: &Simulation) -> f64 {
    let d = sim.state.poses[0].p * Vector3::x();
    d.x.atan2(-d.z)
}

/// I_O of the bundled bar about its pivot, and the small-amplitude period.
fn pendulum_constants() -> (f64, f64) {
    let scene = bundled("pendulum");
    let b = &scene.model.bodies[0];
    let i_o = b.inertia[(1, 1)] + b.mass * 0.25;
    (
        i_o,
        2.0 * std::f64::consts::PI * (i_o / (b.mass * G * 0.5)).sqrt(),
    )
}

#[test]
fn small_amplitude_period_matches_the_compound_pendulum() {
    let (_, period) = pendulum_constants();
    let mut sim = pendulum(0.05, Scheme::CombinedProjection, 1e-3);
    let mut crossings = Vec::new();
    let mut last = angle(&sim);
    sim.run_until(10.0, |s, _| {
        let a = angle(s);
        if last > 0.0 && a <= 0.0 {
            // linear interpolation of the downward zero crossing
            crossings.push(s.state.t - s.params.h * a / (a - last));
        }
        last = a;
    })
    .unwrap();
    assert!(crossings.len() >= 5);
    let measured = (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
    let rel = (measured - period).abs() / period;
    eprintln!("period {measured:.6} s vs {period:.6} s ({rel:.2e})");
    assert!(rel < 5e-3, "period {measured} vs {period}");
}

/// θ'' = −(m g L/2 / I_O) sin θ by RK4 with a fine step.
fn rk4_angle(theta0: f64, t_end: f64, k: f64) -> f64 {
    common::rk4_angle_from_rest(theta0, t_end, 200_000, |th| -k * th.sin())
}

#[test]
fn horizontal_release_converges_to_the_exact_ode() {
    let (i_o, _) = pendulum_constants();
    let k = 1.0 * G * 0.5 / i_o;
    let t_end = 1.5;
    let reference = rk4_angle(std::f64::consts::FRAC_PI_2, t_end, k);
    let hs = [4e-3, 2e-3, 1e-3, 5e-4];
    let errs: Vec<f64> = hs
        .iter()
        .map(|&h| {
            let mut sim = pendulum(std::f64::consts::FRAC_PI_2, Scheme::CombinedProjection, h);
            sim.run_until(t_end, |_, _| {}).unwrap();
            (angle(&sim) - reference).abs()
        })
        .collect();
    let order = loglog_slope(&hs, &errs);
    eprintln!("angle errors {errs:?}, order {order:.2}");
    // the midpoint joint rows make the scheme second order (frozen rows: first order)
    assert!(order >= 1.8, "measured order {order}");
    assert!(errs[2] < 2e-5, "error at h = 1 ms: {}", errs[2]);
}

#[test]
fn projection_removes_the_joint_drift_of_the_plain_scheme() {
    let mut combined = pendulum(
        std::f64::consts::FRAC_PI_2,
        Scheme::CombinedProjection,
        1e-3,
    );
    let mut worst_step: f64 = 0.0;
    combined
        .run_until(10.0, |s, _| {
            worst_step = worst_step.max(s.stats.max_joint_violation)
        })
        .unwrap();
    assert_eq!(combined.stats.steps, 10_000);
    assert!(
        worst_step < 1e-9,
        "combined-projection joint violation {worst_step:e} m"
    );
    assert_eq!(combined.stats.projection_failures, 0);

    let mut plain = pendulum(std::f64::consts::FRAC_PI_2, Scheme::MoreauJean, 1e-3);
    plain.run_until(10.0, |_, _| {}).unwrap();
    let drift = plain.stats.max_joint_violation;
    eprintln!("joint violation: combined {worst_step:e} m, plain {drift:e} m");
    assert!(
        drift > 1e-7,
        "the plain scheme should drift measurably, got {drift:e} m"
    );
}

#[test]
fn combined_projection_ball_never_penetrates() {
    for e in [0.0, 0.9, 1.0] {
        for h in [0.05, 0.01, 1e-3, 1e-4] {
            let mut scene = bundled("bouncing-ball");
            scene.model.contacts[0].e = e;
            scene.params.h = h;
            scene.params.scheme = Scheme::CombinedProjection;
            let mut sim = simulation(scene);
            sim.run_until(if h < 1e-3 { 3.0 } else { 10.0 }, |_, _| {})
                .unwrap();
            let pen = sim.stats.max_penetration;
            assert!(pen <= 1e-10, "e = {e}, h = {h}: penetration {pen:e}");
            assert_eq!(sim.stats.projection_failures, 0, "e = {e}, h = {h}");
        }
    }
}

/// E(10)/E0 and the largest penetration of each scheme on the elastic ball: the table in
/// the README (run with `--nocapture` to print it).
#[test]
fn scheme_table_for_the_elastic_ball() {
    eprintln!("| scheme | h (s) | E(10)/E0 | max penetration (m) |");
    eprintln!("|---|---|---|---|");
    for scheme in [
        Scheme::MoreauJean,
        Scheme::CombinedProjection,
        Scheme::DirectProjection,
    ] {
        for h in [0.05, 0.01, 1e-3, 1e-4] {
            let mut scene = bundled("bouncing-ball");
            scene.model.contacts[0].e = 1.0;
            scene.params.h = h;
            scene.params.scheme = scheme;
            let mut sim = simulation(scene);
            let e0 = sim.energy();
            sim.run_until(10.0, |_, _| {}).unwrap();
            let ratio = sim.energy() / e0;
            let pen = sim.stats.max_penetration;
            eprintln!("| {} | {h:e} | {ratio:.6} | {pen:.2e} |", scheme.name());
            if scheme == Scheme::CombinedProjection {
                assert!(
                    pen <= 1e-10 && (ratio - 1.0).abs() < 0.05,
                    "h = {h}: E ratio {ratio}, penetration {pen:e}"
                );
            }
        }
    }
}

#[test]
fn driven_four_bar_closes_its_loop_and_follows_the_crank_profile() {
    let mut sim = simulation(bundled("four-bar"));
    let omega = 2.0 * std::f64::consts::PI;
    let mut worst_angle: f64 = 0.0;
    let mut worst_loop: f64 = 0.0;
    sim.run_until(10.0, |s, _| {
        worst_loop = worst_loop.max(s.stats.max_joint_violation);
        let crank = s.model.joints[0].coordinate(&s.state.poses);
        let err = (crank - omega * s.state.t + std::f64::consts::PI)
            .rem_euclid(2.0 * std::f64::consts::PI)
            - std::f64::consts::PI;
        worst_angle = worst_angle.max(err.abs());
    })
    .unwrap();
    eprintln!("four-bar: loop closure {worst_loop:e} m, crank angle error {worst_angle:e} rad");
    assert_eq!(sim.stats.steps, 10_000);
    assert!(worst_loop < 1e-9, "loop closure error {worst_loop:e} m");
    assert!(worst_angle < 1e-9, "crank angle error {worst_angle:e} rad");
    assert_eq!(sim.stats.newton_failures + sim.stats.projection_failures, 0);
    // the rocker really rocks: its angular velocity changes sign
    let rocker = sim.model.body_index("rocker").unwrap();
    assert!(sim.state.v[6 * rocker + 4].abs() > 0.0);
}

#[test]
fn joint_limits_stop_the_swing() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/pendulum/scene.yaml");
    let text = std::fs::read_to_string(path).unwrap();
    for e in [0.0, 1.0] {
        let yaml = text.replace(
            "    axis: [0, 1, 0]\n",
            &format!(
                "    axis: [0, 1, 0]\n    limits: {{ lower: -10 deg, upper: 120 deg, e: {e} }}\n"
            ),
        );
        let scene = mc_study::scene::Scene::from_yaml(&yaml, "pendulum-limits").unwrap();
        let upper = 120f64.to_radians();
        let mut sim = simulation(scene);
        let e0 = sim.energy();
        let mut max_q = f64::MIN;
        let mut hits = 0;
        sim.run_until(4.0, |s, _| {
            max_q = max_q.max(s.model.joints[0].coordinate(&s.state.poses));
            let stop = s.contact_points().len() - 1;
            hits += usize::from(s.impulses()[stop].x > 0.0);
        })
        .unwrap();
        // energy relative to the swing's scale m g L/2 (E0 = 0 at the horizontal release)
        let swing = 1.0 * 9.81 * 0.5;
        let change = (sim.energy() - e0) / swing;
        eprintln!("limits, e = {e}: max angle {max_q:.12} (stop {upper:.12}), {hits} stop steps, ΔE/(mgL/2) {change:.3e}");
        assert!(
            max_q <= upper + 1e-10,
            "e = {e}: went through the stop: {max_q}"
        );
        // the combined scheme reflects where the step would cross the stop: within ω h
        assert!(
            max_q >= upper - 5e-3,
            "e = {e}: never reached the stop: {max_q}"
        );
        assert!(hits >= 1);
        assert!(sim.stats.max_penetration <= 1e-10);
        if e == 1.0 {
            assert!(
                change.abs() < 1e-3,
                "elastic stop changed the energy by {change}"
            );
        } else {
            assert!(
                change < -0.1,
                "a plastic stop dissipates the swing's energy: {change}"
            );
        }
    }
}

/// A bar pinned at one end and resting at the other on a support shares its weight by the
/// lever rule: m g/2 on each. The contact's response is constrained by the pin (the joint
/// rows are eliminated), and the pin's reaction is what the contact leaves: a wrong sign in
/// either gives 0 or 3/2 m g at the pin.
#[test]
fn a_pinned_bar_on_a_support_shares_its_weight_by_the_lever_rule() {
    let yaml = "
name: lever
duration: 0.2 s
gravity: [0, -9.81, 0]
integrator: { h: 1 ms, scheme: combined-projection }
bodies:
  - { name: bar, mass: 1 kg, shape: { box: { size: [1 m, 20 mm, 20 mm] } }, position: [0.5 m, 0, 0] }
joints:
  - { name: pin, type: revolute, body_a: ground, body_b: bar, anchor: [0, 0, 0], axis: [0, 0, 1] }
contacts:
  - name: support
    body: bar
    shape: { sphere: { radius: 10 mm, center: [0.5 m, 0, 0] } }
    against: ground
    against_shape: { box: { size: [0.1 m, 0.1 m, 0.1 m], center: [1 m, -60 mm, 0] } }
    mu: 0.5
    e: 0
";
    let scene = mc_study::scene::Scene::from_yaml(yaml, "lever").unwrap();
    let h = scene.params.h;
    let mut sim = simulation(scene);
    sim.run_until(0.2, |_, _| {}).unwrap();
    let half_weight = 0.5 * 1.0 * G * h;
    let support: f64 = sim.impulses().iter().map(|p| p.x).sum();
    let pin = sim.joint_impulses();
    eprintln!("support {support:.9e}, pin {pin:?}, m g h/2 {half_weight:.9e}");
    assert!((support - half_weight).abs() < 1e-6 * half_weight);
    // the pin's rows: world x, y, z, then the two angular rows
    assert!((pin[1] - half_weight).abs() < 1e-6 * half_weight);
    for k in [0, 2, 3, 4] {
        assert!(pin[k].abs() < 1e-9 * half_weight, "row {k}: {}", pin[k]);
    }
    assert!(sim.stats.max_penetration < 1e-9);
}
