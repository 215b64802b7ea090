//! A step ends at each knot of a prescribed load's table: the θ-rule integrates a load that
//! is linear over the step exactly into the velocity, but one step across a knot misses
//! the load's bend by an error of first order in the step, for good.

mod common;

use mc_study::scene::Scene;

/// A 1 kg body, no gravity, pushed along x by a force rising linearly from 0 to 1 N over
/// 0 ≤ t ≤ 10.5 ms and constant after it, at h = 1 ms: the knot falls mid-step.
fn pushed(table: &str) -> Scene {
    let yaml = format!(
        "
duration: 20 ms
gravity: [0, 0, 0]
integrator: {{ h: 1 ms, scheme: moreau-jean }}
bodies:
  - {{ name: block, mass: 1 kg, shape: {{ box: {{ size: [0.1, 0.1, 0.1] }} }} }}
forces:
  - load: {{ body: block, force_table: {table} }}
"
    );
    Scene::from_yaml(&yaml, "pushed").unwrap_or_else(|e| panic!("{e}"))
}

/// v(T) = F₁ (T − t_k/2) / m after the ramp, exactly as the θ-rule takes it when a step
/// ends at the knot; a step across it (10 to 11 ms) takes the mean of the ends, 0.976 N,
/// against the true 0.988 N, and leaves 1.2e-5 m/s for good. The position, of second order
/// on the ramp, is within h³/12 · F′/m per step of x(T) = t_k²/6 + (t_k/2)(T − t_k) +
/// (T − t_k)²/2.
#[test]
fn a_step_ends_at_the_knot_of_a_force_table() {
    let (tk, t_end) = (10.5e-3, 20e-3);
    let mut sim = common::simulation(pushed(
        "[[0, 0, 0, 0], [10.5 ms, 1 N, 0, 0], [1 s, 1 N, 0, 0]]",
    ));
    let mut ends = Vec::new();
    sim.run_until(t_end, |s, _| ends.push(s.state.t)).unwrap();
    assert!(
        ends.iter().any(|&t| (t - tk).abs() < 1e-15),
        "no step ends at the knot: {ends:?}"
    );
    let v = sim.state.v[0];
    let v_exact = t_end - 0.5 * tk;
    assert!((v - v_exact).abs() < 1e-12, "v = {v}, exact {v_exact}");
    let x = sim.state.poses[0].x.x;
    let x_exact = tk * tk / 6.0 + 0.5 * tk * (t_end - tk) + 0.5 * (t_end - tk).powi(2);
    let ramp_error = (tk / 1e-3).ceil() * 1e-9 / 12.0 / tk;
    assert!(
        (x - x_exact).abs() < 1.5 * ramp_error,
        "x = {x}, exact {x_exact}, allowed {ramp_error}"
    );
    // a knot on the grid adds no step: 20 steps of 1 ms
    let mut on_grid = common::simulation(pushed(
        "[[0, 0, 0, 0], [10 ms, 1 N, 0, 0], [1 s, 1 N, 0, 0]]",
    ));
    let mut count = 0;
    on_grid.run_until(t_end, |_, _| count += 1).unwrap();
    assert_eq!(count, 20);
    assert!((on_grid.state.v[0] - (t_end - 5e-3)).abs() < 1e-12);
}
