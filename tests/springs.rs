//! Force elements in the θ-scheme: a mass on a point spring against the analytic harmonic
//! oscillator (period, energy, damping decay), stiff springs far beyond the explicit
//! stability limit, and a torsional spring with preload.

mod common;

use mc_study::integrator::Simulation;
use mc_study::scene::Scene;

fn oscillator(k: f64, c: f64, h: f64) -> Simulation {
    let yaml = format!(
        r#"
duration: 1 s
gravity: [0, 0, 0]
integrator: {{ h: {h}, scheme: moreau-jean }}
bodies:
  - name: m
    mass: 2 kg
    shape: {{ sphere: {{ radius: 0.05 }} }}
    position: [0.1, 0, 0]
forces:
  - spring: {{ body_a: m, body_b: ground, point_b: [0, 0, 0], stiffness: {k}, damping: {c}, rest_length: 0 }}
"#
    );
    common::simulation(Scene::from_yaml(&yaml, "oscillator").unwrap_or_else(|e| panic!("{e}")))
}

#[test]
fn undamped_spring_matches_the_harmonic_oscillator() {
    let (k, m): (f64, f64) = (800.0, 2.0);
    let omega = (k / m).sqrt();
    let mut sim = oscillator(k, 0.0, 1e-4);
    let e0 = sim.energy();
    let mut worst_e: f64 = 0.0;
    let mut worst_x: f64 = 0.0;
    sim.run_until(1.0, |s, r| {
        assert!(r.newton_converged);
        worst_e = worst_e.max((s.energy() - e0).abs() / e0);
        let exact = 0.1 * (omega * s.state.t).cos();
        worst_x = worst_x.max((s.state.poses[0].x.x - exact).abs());
    })
    .unwrap();
    // trapezoidal rule: energy exact for a linear spring, phase error O((ωh)²)
    assert!(worst_e < 1e-9, "energy error {worst_e:e}");
    // the trapezoidal rule's relative frequency error is (ωh)²/12: after 1 s the phase lags
    // by ω·1 s·(ωh)²/12, i.e. 0.1 m × that in position
    let predicted = 0.1 * omega * (omega * 1e-4).powi(2) / 12.0;
    assert!(
        worst_x < 2.0 * predicted && worst_x > 0.2 * predicted,
        "position error {worst_x:e} vs {predicted:e}"
    );
}

#[test]
fn damped_spring_decays_at_the_analytic_rate() {
    let (k, m, c): (f64, f64, f64) = (800.0, 2.0, 8.0);
    let zeta = c / (2.0 * (k * m).sqrt());
    let omega = (k / m).sqrt();
    let mut sim = oscillator(k, c, 1e-4);
    sim.run_until(1.0, |_, _| {}).unwrap();
    // x(t) = A e^{−ζωt}(cos ω_d t + ζω/ω_d sin ω_d t)
    let wd = omega * (1.0 - zeta * zeta).sqrt();
    let t = sim.state.t;
    let exact =
        0.1 * (-zeta * omega * t).exp() * ((wd * t).cos() + zeta * omega / wd * (wd * t).sin());
    let x = sim.state.poses[0].x.x;
    assert!((x - exact).abs() < 1e-5, "x = {x}, exact {exact}");
}

#[test]
fn stiff_spring_stays_stable_far_beyond_the_explicit_limit() {
    // k h²/m from 1e-6 to 1e2: the implicit θ = 1/2 step never blows up and keeps energy
    for khm in [1e-6, 1e-2, 1.0, 1e2] {
        let h = 1e-3;
        let k = khm * 2.0 / (h * h);
        let mut sim = oscillator(k, 0.0, h);
        let e0 = sim.energy();
        sim.run_until(0.5, |s, r| {
            assert!(r.newton_converged && s.energy().is_finite())
        })
        .unwrap();
        let drift = (sim.energy() - e0).abs() / e0;
        assert!(drift < 1e-8, "k h²/m = {khm}: energy drift {drift:e}");
    }
}

#[test]
fn torsional_spring_with_preload_holds_its_equilibrium() {
    // a wheel on a spherical pivot with a torsional spring about z: preload M0 = 0.5 N m
    // and stiffness 2 N m/rad settle (damping ratio 0.5) at φ = −M0/k = −0.25 rad
    let yaml = r#"
duration: 5 s
gravity: [0, 0, 0]
integrator: { h: 1 ms }
bodies:
  - name: wheel
    mass: 1 kg
    inertia: [0.01, 0.01, 0.02]
    motion: pinned
forces:
  - torsional_spring: { body_a: ground, body_b: wheel, axis: [0, 0, 1], stiffness: 2 N*m, preload: 0.5 N*m, damping: 0.2 N*m*s }
"#;
    let mut sim =
        common::simulation(Scene::from_yaml(yaml, "torsion").unwrap_or_else(|e| panic!("{e}")));
    sim.run_until(5.0, |_, _| {}).unwrap();
    let p = sim.state.poses[0].p;
    let angle = p.scaled_axis().z;
    assert!((angle + 0.25).abs() < 1e-6, "equilibrium angle {angle}");
}
