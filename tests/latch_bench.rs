//! The virtual test bench: a spring-loaded latch lifted by a ramp pushed at 4 mm/s, its
//! push force against the latch angle set against the hand formula along the ramp, and its
//! quasi-static peak (the peak of the force's mean over 20 ms) at two step sizes.

use mc_study::probe::run::run_probes;
use mc_study::scene::Scene;
use mc_study::single_run::trajectory::Trajectory;

/// The latch (L = 40 mm from its pivot to its nose, a sphere of ρ = 0.5 mm) is held down
/// by a torsional spring M(θ) = M₀ + k θ; the slider's ramp, at α = 30°, rises 6 mm from
/// a lower flat to an upper one and is pushed along x at 4 mm/s; μ = 0.2 at the nose; no
/// gravity, so that the bench is quasi-static.
const BENCH: &str = r#"
name: latch-bench
duration: 3.5 s
gravity: [0, 0, 0]
integrator: { h: 1 ms }
bodies:
  - { name: latch, mass: 5 g, shape: { box: { size: [40 mm, 4 mm, 4 mm] } }, position: [20 mm, 0, 0] }
  - { name: slider, mass: 50 g, shape: { box: { size: [60 mm, 5 mm, 5 mm] } }, position: [30 mm, -10 mm, 0] }
joints:
  - { name: pivot, type: revolute, body_a: ground, body_b: latch, anchor: [0, 0, 0], axis: [0, 0, 1] }
  - { name: slide, type: prismatic, body_a: ground, body_b: slider, anchor: [30 mm, -10 mm, 0], axis: [1, 0, 0],
      drive: { velocity: 4 mm/s } }
forces:
  - torsional_spring: { body_a: ground, body_b: latch, axis: [0, 0, 1], stiffness: 0.2 N*m, preload: 0.05 N*m }
contacts:
  - name: nose
    body: latch
    shape: { sphere: { radius: 0.5 mm, center: [20 mm, 0, 0] } }
    against: slider
    against_shape:
      profile:
        thickness: 5 mm
        solid: right
        start: [-30 mm, 15.5 mm]
        path:
          - line: [-1.392305 mm, 15.5 mm]
          - line: [9 mm, 9.5 mm]
          - line: [30 mm, 9.5 mm]
    mu: 0.2
probes:
  - { name: lift, measure: { angle: pivot } }
  - { name: push_peak, measure: { drive_effort: slide }, reduce: max, mean_over: 20 ms }
"#;

const M0: f64 = 0.05;
const K: f64 = 0.2;
const L: f64 = 0.04;
const MU: f64 = 0.2;
const RHO: f64 = 0.5e-3;

/// The push that holds the latch at angle θ on a face inclined at α, quasi-statically: the
/// nose's normal force P and friction μP (opposing its climb) balance the spring about the
/// pivot, P (L (cos(θ+α) − μ sin(θ+α)) + μ ρ) = M₀ + k θ (the μ ρ term: friction acts at
/// the sphere's surface, ρ below its centre), and the slider takes P (sin α + μ cos α).
fn hand_push(theta: f64, alpha: f64) -> f64 {
    (M0 + K * theta) * (alpha.sin() + MU * alpha.cos())
        / (L * ((theta + alpha).cos() - MU * (theta + alpha).sin()) + MU * RHO)
}

#[test]
fn the_push_curve_and_its_quasi_static_peak_match_the_hand_formula() {
    let alpha = 30f64.to_radians();
    // at the ramp's top the nose's centre is ρ along the ramp's normal from the corner,
    // which stands 5.5 mm above the pivot
    let top = ((5.5e-3 + RHO * alpha.cos()) / L).asin();
    let peak = hand_push(top, alpha);
    for h in ["1 ms", "0.25 ms"] {
        let text = BENCH.replace("h: 1 ms", &format!("h: {h}"));
        let scene = Scene::from_yaml(&text, "latch-bench").unwrap();
        let sim = scene.simulation().unwrap();
        let mut curves = Trajectory::for_simulation(&sim, &scene.probes);
        let run = run_probes(sim, &scene.probes, scene.duration, false, |s, _, _| {
            curves.record(s)
        });
        assert!(run.error.is_none(), "{:?}", run.error);
        let (theta, push) = (
            curves.column("probe.lift").unwrap(),
            curves.column("slide.effort").unwrap(),
        );
        // the curve, wherever the nose is on the ramp
        let mut checked = 0;
        for (&th, &f) in theta.iter().zip(push) {
            if th > 0.01 && th < top - 0.005 {
                let exact = hand_push(th, alpha);
                assert!(
                    (f - exact).abs() < 0.01 * exact,
                    "h = {h}, θ = {th}: {f} N against {exact} N"
                );
                checked += 1;
            }
        }
        assert!(checked > 1000, "h = {h}: {checked} points on the ramp");
        let got = run.values[1].clone().unwrap();
        assert!(
            (got - peak).abs() < 0.01 * peak,
            "h = {h}: quasi-static peak {got} N against {peak} N"
        );
    }
}
