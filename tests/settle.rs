//! The settling phase (`settle:`): the damping −α M v of every body until `until`, and the
//! contacts that lose their friction during it, against closed-form motions.

mod common;

use mc_study::scene::Scene;

const G: f64 = 9.81;

/// A free box, no gravity, no contact, moving and spinning, h = 1 ms, under `settle`.
fn free_box(settle: &str) -> Scene {
    let yaml = format!(
        "
duration: 1 s
gravity: [0, 0, 0]
integrator: {{ h: 1 ms }}
{settle}
bodies:
  - name: box
    mass: 2 kg
    shape: {{ box: {{ size: [0.2, 0.1, 0.05] }} }}
    velocity: [1, -2, 0.5]
    angular_velocity: [0, 0, 3]
"
    );
    Scene::from_yaml(&yaml, "settle").unwrap_or_else(|e| panic!("{e}"))
}

/// The free box damped at α = 10/s until 0.5 s.
#[test]
fn settle_damping_decays_the_velocity_as_exp_minus_alpha_t_then_stops_acting() {
    let scene = free_box("settle: { until: 0.5 s, damping: 10 Hz }");
    let mut sim = common::simulation(scene);
    let v0 = sim.state.v.clone();
    sim.run_until(0.5, |_, _| {}).unwrap();
    // θ = 1/2 multiplies v by (1 − hα/2)/(1 + hα/2) a step: exp(−αt) to O(h²)
    let decay = (-10.0f64 * 0.5).exp();
    for k in [0, 1, 2, 5] {
        let rel = (sim.state.v[k] / v0[k] - decay).abs() / decay;
        assert!(
            rel < 1e-4,
            "dof {k}: v/v0 = {}, exp(−5) = {decay}",
            sim.state.v[k] / v0[k]
        );
    }
    let v_end = sim.state.v.clone();
    sim.run_until(1.0, |_, _| {}).unwrap();
    assert!(
        (&sim.state.v - &v_end).norm() < 1e-12 * v_end.norm(),
        "the damping must stop at `until`"
    );
}

/// A block on a 30° slope with μ = 1 (> tan 30°) sticks; with `friction: []` it slides
/// freely during the settle, at g sin β, then friction brakes it at g (μ cos β − sin β).
fn slope(settle: &str) -> mc_study::integrator::Simulation {
    let b = 30f64.to_radians();
    let yaml = format!(
        "
duration: 1 s
integrator: {{ h: 1 ms, solver: {{ tolerance: 1e-12 }} }}
{settle}
bodies:
  - name: block
    mass: 1 kg
    shape: {{ box: {{ size: [0.2, 0.2, 0.05] }} }}
    orientation: {{ axis: [0, 1, 0], angle: 30 deg }}
    position: [{}, 0, {}]
contacts:
  - name: slope
    body: block
    shape: {{ box: {{ size: [0.2, 0.2, 0.05] }} }}
    against_shape: {{ plane: {{ normal: [{}, 0, {}] }} }}
    mu: 1
",
        0.025 * b.sin(),
        0.025 * b.cos(),
        b.sin(),
        b.cos()
    );
    common::simulation(Scene::from_yaml(&yaml, "slope").unwrap_or_else(|e| panic!("{e}")))
}

fn speed(sim: &mc_study::integrator::Simulation) -> f64 {
    sim.state.v.fixed_rows::<3>(0).norm()
}

#[test]
fn a_frictionless_settle_lets_a_stuck_block_slide_until_friction_returns() {
    let (h, b, mu) = (1e-3, 30f64.to_radians(), 1.0);
    let mut sim = slope("settle: { until: 0.2 s, friction: [] }");
    sim.run_until(0.2, |_, _| {}).unwrap();
    let v_settle = G * b.sin() * 0.2;
    assert!(
        (speed(&sim) - v_settle).abs() < 1e-9,
        "speed at the end of the settle {} vs g sin β t = {v_settle}",
        speed(&sim)
    );
    let t_stop = 0.2 + v_settle / (G * (mu * b.cos() - b.sin()));
    let mut stop = None;
    sim.run_until(1.0, |s, _| {
        if stop.is_none() && speed(s) < 1e-12 {
            stop = Some(s.state.t);
        }
    })
    .unwrap();
    let stop = stop.expect("friction stops the block once the settle is over");
    assert!(
        (stop - t_stop).abs() <= h,
        "stopped at {stop}, analytic {t_stop}"
    );

    // the contact named in `friction` keeps it: the block never moves
    let mut kept = slope("settle: { until: 0.2 s, friction: [slope] }");
    kept.run_until(0.3, |s, _| assert!(speed(s) < 1e-12))
        .unwrap();
}

/// `settle: { h }`: the settle takes its own step, its last one shortened to end exactly at
/// `until`, and the integrator's h follows; a fidelity that changes h scales the settle's
/// step with it. Under the damping alone each step of size s multiplies the velocity by
/// (1 − sα/2)/(1 + sα/2), so the velocity at `until` tells the steps taken: 50 steps of
/// 10 ms and one of 3 ms here, against 503 of 1 ms (a relative difference of 4e-3).
#[test]
fn the_settle_takes_its_own_step_and_ends_at_until() {
    let factor = |s: f64| (1.0 - 5.0 * s) / (1.0 + 5.0 * s);
    for (h, settle_steps, last) in [(1e-3, 50, 3e-3), (0.5e-3, 100, 3e-3)] {
        let mut scene = free_box("settle: { until: 0.503 s, damping: 10 Hz, h: 10 ms }");
        scene.params.h = h; // as a study's `fidelity: { h }` does
        let mut sim = common::simulation(scene);
        let v0 = sim.state.v[0];
        let mut ends = Vec::new();
        sim.run_until(1.0, |s, _| ends.push((s.state.t, s.h(), s.state.v[0])))
            .unwrap();
        let settle_end = ends
            .iter()
            .position(|&(t, _, _)| t == 0.503)
            .expect("a step ends exactly at `until`");
        assert_eq!(
            settle_end, settle_steps,
            "h = {h}: steps before the last settle step"
        );
        assert!((ends[settle_end].1 - last).abs() < 1e-15);
        assert!(
            (ends[0].1 / (10.0 * h) - 1.0).abs() < 1e-12,
            "settle step {}",
            ends[0].1
        );
        let expected = factor(10.0 * h).powi(settle_steps as i32) * factor(last);
        let v = ends[settle_end].2 / v0;
        assert!(
            (v / expected - 1.0).abs() < 1e-12,
            "h = {h}: v/v0 = {v} at `until`, {expected} expected"
        );
        // then h, undamped, to the end
        let after = &ends[settle_end + 1..];
        assert_eq!(after.len(), ((1.0 - 0.503) / h).round() as usize);
        assert!(after.iter().all(|&(_, s, _)| s == h));
        assert!((sim.state.t - 1.0).abs() < 1e-12);
        assert_eq!(
            sim.state.v[0], ends[settle_end].2,
            "no damping after `until`"
        );
    }
}
