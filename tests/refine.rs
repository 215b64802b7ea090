//! The refinement window (`refine:`): the step it takes, where it opens and closes, and
//! that it scales with h, on the bouncing ball.

mod common;

use mc_study::scene::Scene;

/// The e = 0.9 ball from 0.9 m (first impact at t₁ = √(2 · 0.9 / g) = 0.4284 s) at h = 1 ms,
/// with `refine`, run at step `h` (as a study's fidelity would set it).
fn ball(refine: &str, h: f64) -> mc_study::integrator::Simulation {
    let yaml = format!(
        "
duration: 1.3 s
gravity: [0, 0, -9.81]
integrator: {{ h: 1 ms, scheme: moreau-jean }}
{refine}
bodies:
  - name: ball
    mass: 1 kg
    shape: {{ sphere: {{ radius: 0.1 m }} }}
    position: [0, 0, 1 m]
contacts:
  - name: floor
    body: ball
    shape: {{ sphere: {{ radius: 0.1 m }} }}
    against: ground
    against_shape: {{ plane: {{ point: [0, 0, 0], normal: [0, 0, 1] }} }}
    mu: 0
    e: 0.9
"
    );
    let mut scene = Scene::from_yaml(&yaml, "refine").unwrap_or_else(|e| panic!("{e}"));
    scene.params.h = h;
    common::simulation(scene)
}

/// Every step's (start, size) up to 1.3 s (the second impact is at 1.199 s).
fn steps(sim: &mut mc_study::integrator::Simulation) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let mut t = sim.state.t;
    sim.run_until(1.3, |s, _| {
        out.push((t, s.state.t - t));
        t = s.state.t;
    })
    .unwrap();
    out
}

/// The steps are h until the step in which the floor first carries an impulse (the one
/// that ends at t₁ rounded up to the ms), h/10 for the next 50 ms, the last of them ending
/// exactly at the window's end, then h again, also at the second impact (the window opens
/// once); without `refine` every step is h.
#[test]
fn the_window_opens_at_the_first_closing_and_takes_its_own_step() {
    let h = 1e-3;
    let plain = steps(&mut ball("", h));
    assert!(plain.iter().all(|&(_, d)| (d - h).abs() < 1e-12));
    let impact_end = 1e-3 * (0.4284f64 * 1e3).ceil();
    let mut sim = ball("refine: { after: floor, for: 50 ms, h: 0.1 ms }", h);
    let refined = steps(&mut sim);
    let window_end = impact_end + 0.05;
    for &(t, d) in &refined {
        let expected = if t >= impact_end - 1e-9 && t < window_end - 1e-9 {
            h / 10.0
        } else {
            h
        };
        assert!(
            (d - expected).abs() < 1e-9 * h,
            "step at t = {t}: {d}, expected {expected}"
        );
    }
    assert!(
        refined
            .iter()
            .any(|&(t, d)| (t + d - window_end).abs() < 1e-12),
        "a step ends at the window's end {window_end}"
    );
    assert_eq!(refined.len(), plain.len() + 450);
    // the window's step is a ratio of h: a fidelity of h = 0.5 ms makes it 0.05 ms
    let mut half = ball("refine: { after: floor, for: 50 ms, h: 0.1 ms }", 0.5e-3);
    let half_steps = steps(&mut half);
    let finest = half_steps.iter().map(|&(_, d)| d).fold(f64::MAX, f64::min);
    assert!((finest - 0.05e-3).abs() < 1e-12, "{finest}");
}
