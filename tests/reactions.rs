//! Joint reactions against closed forms and statics, and the convergence in h of the
//! window-mean reaction of a rattling clearance joint.

use mc_study::probe::run::run_probes;
use mc_study::scene::Scene;

/// The probe values of `scene` run to its end.
fn probes(scene: &Scene) -> Vec<f64> {
    let sim = scene.simulation().unwrap();
    let run = run_probes(
        sim,
        &scene.probes,
        &scene.curves,
        scene.duration,
        false,
        |_, _, _| {},
    );
    assert!(run.error.is_none(), "{:?}", run.error);
    run.values
        .into_iter()
        .map(|v| v.unwrap_or_else(|e| panic!("{e}")))
        .collect()
}

/// A uniform bar (1 m, 1 kg) on an ideal revolute joint at its end, released horizontal.
const PENDULUM: &str = r#"
name: compound-pendulum
duration: 1 s
gravity: [0, 0, -9.81]
integrator: { h: 0.1 ms }
bodies:
  - { name: bar, mass: 1 kg, shape: { box: { size: [1 m, 20 mm, 20 mm] } }, position: [0.5 m, 0, 0] }
joints:
  - { name: pivot, type: revolute, body_a: ground, body_b: bar, anchor: [0, 0, 0], axis: [0, 1, 0] }
probes:
  - name: bottom
    event: { crosses: 90 deg, measure: { angle: pivot }, direction: up }
  - { name: reaction, measure: { reaction: pivot }, at: bottom }
  - { name: reaction_z, measure: { reaction: pivot, axis: [0, 0, 1] }, at: bottom }
  - { name: reaction_x, measure: { reaction: pivot, axis: [1, 0, 0] }, at: bottom }
  - { name: omega, measure: { angular_velocity: bar }, at: bottom }
"#;

#[test]
fn compound_pendulum_reaction_at_the_bottom_is_m_g_plus_m_omega_squared_r() {
    let scene = Scene::from_yaml(PENDULUM, "pendulum").unwrap();
    let v = probes(&scene);
    let (m, g, r) = (1.0, 9.81, 0.5);
    let b = &scene.model.bodies[0];
    let i_o = b.inertia[(1, 1)] + m * r * r;
    // energy: ½ I_O ω² = m g r at the bottom
    let omega2 = 2.0 * m * g * r / i_o;
    let exact = m * (g + omega2 * r);
    eprintln!(
        "bottom at t = {:.6} s: reaction {:.9} N (z {:.9}, x {:.3e}) vs m(g + ω² r_G) = {exact:.9} N; ω {:.9} vs {:.9}",
        v[0], v[1], v[2], v[3], v[4], omega2.sqrt()
    );
    assert!(
        (v[4] - omega2.sqrt()).abs() < 1e-6 * omega2.sqrt(),
        "ω {}",
        v[4]
    );
    assert!((v[1] - exact).abs() < 1e-5 * exact, "{} vs {exact}", v[1]);
    // upward on the bar, nothing sideways at the bottom (no angular acceleration there)
    assert!((v[2] - exact).abs() < 1e-5 * exact, "{}", v[2]);
    assert!(v[3].abs() < 1e-4 * exact, "{}", v[3]);
}

/// The bar of `PENDULUM` hanging from a clearance joint, settled under gravity and a
/// constant side load at its centre (damped near critically, −α M v with α ≈ 2 ω₀, for 35
/// time constants; after 23 the reaction was still up to 2e-9 of the load off); the net
/// reaction of the joint's contact points must balance the bar's loads.
const HANGING: &str = r#"
name: hanging-on-a-clearance-joint
duration: 9 s
gravity: [0, 0, -9.81]
integrator: { h: 0.5 ms, solver: { tolerance: 1e-12 } }
settle: { until: 9 s, damping: 8 Hz }
bodies:
  - { name: bar, mass: 1 kg, shape: { box: { size: [1 m, 20 mm, 20 mm] } }, position: [0, 0, -0.5 m],
      orientation: { axis: [0, 1, 0], angle: 90 deg } }
joints:
  - { name: pivot, type: revolute-clearance, body_a: ground, body_b: bar, anchor: [0, 0, 0], axis: [0, 1, 0],
      clearance: 0.07 mm, journal_radius: 5 mm, bore_length: 10 mm, mu: 0.1, e: 0 }
forces:
  - name: side
    load: { body: bar, force: [3 N, 0, 0] }
probes:
  - { name: rx, measure: { reaction: pivot, axis: [1, 0, 0] } }
  - { name: ry, measure: { reaction: pivot, axis: [0, 1, 0] } }
  - { name: rz, measure: { reaction: pivot, axis: [0, 0, 1] } }
  - { name: eccentricity, measure: { eccentricity: pivot } }
  - { name: direction, measure: { eccentricity: pivot, angle_from: [1, 0, 0] } }
"#;

#[test]
fn net_clearance_reaction_balances_the_static_loads() {
    for (side, mu) in [(0.0, 0.1), (3.0, 0.1), (-2.0, 0.3)] {
        let scene = Scene::from_yaml(HANGING, "hanging")
            .unwrap()
            .with_parameters(&[("forces.side.load.force.x", side), ("joints.pivot.mu", mu)])
            .unwrap();
        let v = probes(&scene);
        let (mg, c) = (9.81, 7e-5);
        // the reaction on the bar balances gravity and the side load
        let expected = [-side, 0.0, mg];
        let scale = (side * side + mg * mg).sqrt();
        for (k, e) in expected.iter().enumerate() {
            assert!(
                (v[k] - e).abs() < 1e-9 * scale,
                "side {side}, μ {mu}: component {k} = {} vs {e}",
                v[k]
            );
        }
        // the journal rests against the bore, along the load it carries (without friction)
        // or within the friction angle of it
        // (pressed into the wall by at most the projection's tolerance, 1e-10 m; with
        // friction the journal may come to rest slightly tilted, one ring bearing more)
        assert!(
            v[3] <= c + 1e-10 && v[3] >= 0.99 * c,
            "eccentricity {}",
            v[3]
        );
        let load = nalgebra::Vector3::new(side, 0.0, -mg).normalize();
        // angle_from +x about +y: positive from +x towards −z
        let offset = nalgebra::Vector3::new(v[4].cos(), 0.0, -v[4].sin());
        let off_angle = load.dot(&offset).clamp(-1.0, 1.0).acos();
        assert!(
            off_angle <= mu.atan() + 1e-6,
            "side {side}, μ {mu}: the journal rests {off_angle} rad off the load line"
        );
    }
}

/// A slider-crank spun up from rest in 5 ms: the spin-up throws the rod's eye against the
/// crank pin (a rattle of impacts over the first revolution), then the pin slides in
/// contact. The window means of the pin's net reaction, over the rattle and after it, and
/// the largest impact impulse converge as h falls: 1e-5 and 3e-6 agree to 0.3 %, and
/// both to 0.4 % with 2e-6 (at 3e-5 the rattle's mean is still 0.7 % off). (With joints
/// held on the mean velocity of each step, impacts excited an undamped alternation that kept the joint rattling:
/// 303 N after the rattle at h = 0.1 ms and 159 N at 10 µs, for 11.4 N.)
#[test]
fn window_mean_reaction_of_a_rattling_clearance_joint_converges_in_h() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("studies/slider-crank-clearance/scene.yaml");
    let omega = 10.0 * std::f64::consts::PI;
    let ramp = 5e-3;
    let text = std::fs::read_to_string(path)
        .unwrap()
        .replace(
            "drive: { velocity: 31.41592653589793 }",
            &format!(
                "drive: {{ position_table: [[0, 0], [{ramp}, {}], [10, {}]] }}",
                0.5 * omega * ramp,
                omega * (10.0 - 0.5 * ramp)
            ),
        )
        .replace("duration: 2 s", "duration: 0.3 s")
        + r#"
probes:
  - { name: rattle, measure: { reaction: crank-rod }, reduce: mean, from: 0 s, to: 0.1 s }
  - { name: after, measure: { reaction: crank-rod }, reduce: mean, from: 0.1 s, to: 0.3 s }
  - { name: largest_impact, measure: { impulse: crank-rod }, reduce: max, from: 0 s, to: 0.1 s }
  - { name: largest_after, measure: { impulse: crank-rod }, reduce: max, from: 0.1 s, to: 0.3 s }
"#;
    let scene = Scene::from_yaml(&text, "slider-crank").unwrap();
    let at = |h: f64| probes(&scene.with_parameters(&[("integrator.h", h)]).unwrap());
    let (coarse, fine) = (at(1e-5), at(3e-6));
    eprintln!("h = 1e-5: {coarse:?}\nh = 3e-6: {fine:?}");
    for k in 0..3 {
        assert!(
            (coarse[k] - fine[k]).abs() < 5e-3 * fine[k].abs(),
            "output {k}: {} at 1e-5, {} at 3e-6",
            coarse[k],
            fine[k]
        );
    }
    // a rattle happened (impacts of a third of a newton-second), and it died out: after it
    // the largest impulse of a step is the step's share of a contact force
    assert!(fine[2] > 0.2, "largest impact {}", fine[2]);
    assert!(
        fine[3] < 1e-3 && fine[3] < 0.5 * coarse[3],
        "{} {}",
        fine[3],
        coarse[3]
    );
    assert!(
        fine[1] > 5.0 && fine[1] < 20.0,
        "after the rattle: {} N",
        fine[1]
    );
}

/// The curves `simulate --out` records, against closed forms on the bar of `PENDULUM`:
/// released horizontal, its pivot carries m g − m a_G = m g (1 − m r² / I_O) upward at
/// once; driven at a constant 2 rad/s, its drive's torque is the weight's moment
/// m g r cos θ (no angular acceleration); and a value probe's column is its measure.
#[test]
fn the_trajectory_records_reactions_drive_efforts_and_probe_measures() {
    use mc_study::single_run::trajectory::Trajectory;
    let scene = Scene::from_yaml(PENDULUM, "pendulum").unwrap();
    let mut sim = scene.simulation().unwrap();
    let mut curves = Trajectory::for_simulation(&sim, &scene.probes);
    for _ in 0..3 {
        sim.step().unwrap();
        curves.record(&sim);
    }
    let (m, g, r) = (1.0, 9.81, 0.5);
    let i_o = scene.model.bodies[0].inertia[(1, 1)] + m * r * r;
    let released = m * g * (1.0 - m * r * r / i_o);
    let fz = curves.column("pivot.fz").unwrap();
    assert!(
        (fz[0] - released).abs() < 1e-3 * released,
        "{fz:?} vs {released}"
    );
    assert!(curves.column("pivot.fx").unwrap()[0].abs() < 1e-3);
    // the probe columns: `reaction_z` is the pivot's z force
    assert_eq!(curves.column("probe.reaction_z").unwrap(), fz);

    let driven = PENDULUM.replace(
        "axis: [0, 1, 0] }",
        "axis: [0, 1, 0], drive: { velocity: 2 rad/s } }",
    );
    let scene = Scene::from_yaml(&driven, "driven").unwrap();
    let mut sim = scene.simulation().unwrap();
    let mut curves = Trajectory::for_simulation(&sim, &scene.probes);
    for _ in 0..5000 {
        sim.step().unwrap();
        curves.record(&sim);
    }
    let (effort, angle) = (
        curves.column("pivot.effort").unwrap(),
        curves.column("probe.reaction").map(|_| ()),
    );
    assert!(angle.is_some());
    let t = curves.column("t").unwrap();
    // a position drive's effort is its step mean: it stands at the step's middle
    let h = scene.params.h;
    for k in [1000, 2500, 4000] {
        let theta = 2.0 * (t[k] - 0.5 * h);
        // about +y, a bar along +x falls with +θ: the drive holds it back
        let exact = -m * g * r * theta.cos();
        assert!(
            (effort[k] - exact).abs() < 1e-3 * m * g * r,
            "t = {}: {} vs {exact}",
            t[k],
            effort[k]
        );
    }
}
