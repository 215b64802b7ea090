//! Assembly at t = 0 against closed forms: a four-bar whose link lengths are parameters
//! (body-frame pins) assembled at a given crank angle gives the rocker angle of
//! Freudenstein's equation; a slider-crank's stroke is twice its crank radius; velocities
//! are made consistent with the drive; a mechanism that cannot close names its joint.

use mc_study::scene::Scene;
use std::f64::consts::PI;

/// A crank-rocker four-bar in the x–y plane (axes z): ground pivots A = (0, 0) and
/// D = (d, 0); crank a, coupler b, rocker c, each a bar whose frame sits at its centre with
/// body x along it; the pins are written in the bodies' frames, so each link length is a
/// parameter (`joints.B.anchor_a.x` is half the crank). The poses are written for the
/// nominal lengths with the crank along +x; `joints.A.initial.angle` turns it.
const FOUR_BAR: &str = r#"
name: four-bar-lengths
duration: 1 ms
gravity: [0, 0, 0]
integrator: { h: 1 ms }
bodies:
  - { name: crank, mass: 0.1, shape: { box: { size: [0.1, 0.01, 0.01] } }, position: [0.05, 0, 0] }
  - { name: coupler, mass: 0.3, shape: { box: { size: [0.35, 0.01, 0.01] } },
      position: [0.2021, 0.1421, 0], orientation: { axis: [0, 0, 1], angle: 0.948 } }
  - { name: rocker, mass: 0.3, shape: { box: { size: [0.3, 0.01, 0.01] } },
      position: [0.3521, 0.1421, 0], orientation: { axis: [0, 0, 1], angle: 1.896 } }
joints:
  - { name: A, type: revolute, body_a: ground, body_b: crank, anchor_a: [0, 0, 0], anchor_b: [-0.05, 0, 0],
      axis_a: [0, 0, 1], axis_b: [0, 0, 1] }
  - { name: B, type: revolute, body_a: crank, body_b: coupler, anchor_a: [0.05, 0, 0], anchor_b: [-0.175, 0, 0],
      axis_a: [0, 0, 1], axis_b: [0, 0, 1] }
  - { name: C, type: revolute, body_a: coupler, body_b: rocker, anchor_a: [0.175, 0, 0], anchor_b: [0.15, 0, 0],
      axis_a: [0, 0, 1], axis_b: [0, 0, 1] }
  - { name: D, type: revolute, body_a: rocker, body_b: ground, anchor_a: [-0.15, 0, 0], anchor_b: [0.4, 0, 0],
      axis_a: [0, 0, 1], axis_b: [0, 0, 1] }
"#;

/// The rocker angle θ₄ (from +x, at D) of Freudenstein's equation
/// K₁ cos θ₄ − K₂ cos θ₂ + K₃ = cos(θ₂ − θ₄), K₁ = d/a, K₂ = d/c,
/// K₃ = (a² − b² + c² + d²)/(2ac), on the branch with the coupler–rocker pin above the
/// ground link: tan(θ₄/2) solves A t² + B t + C = 0 with A = cos θ₂ − K₁ − K₂ cos θ₂ + K₃,
/// B = −2 sin θ₂, C = K₁ − (K₂ + 1) cos θ₂ + K₃.
fn freudenstein(a: f64, b: f64, c: f64, d: f64, theta2: f64) -> f64 {
    let (k1, k2, k3) = (
        d / a,
        d / c,
        (a * a - b * b + c * c + d * d) / (2.0 * a * c),
    );
    let qa = theta2.cos() - k1 - k2 * theta2.cos() + k3;
    let qb = -2.0 * theta2.sin();
    let qc = k1 - (k2 + 1.0) * theta2.cos() + k3;
    let disc = (qb * qb - 4.0 * qa * qc).sqrt();
    [(-qb + disc) / (2.0 * qa), (-qb - disc) / (2.0 * qa)]
        .map(|t| 2.0 * t.atan())
        .into_iter()
        .find(|t4| (c * t4.sin()) > 0.0)
        .expect("a branch with C above the ground link")
}

#[test]
fn four_bar_with_sampled_link_lengths_assembles_on_freudenstein() {
    let scene = Scene::from_yaml(FOUR_BAR, "four-bar").unwrap();
    // link lengths drawn around the nominal (0.1, 0.35, 0.3, 0.4) by a fixed sequence
    let mut x: u64 = 2026;
    let mut draw = || {
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let mut worst: f64 = 0.0;
    for _ in 0..6 {
        let (a, b, c, d) = (
            0.1 * (1.0 + 0.03 * draw()),
            0.35 * (1.0 + 0.03 * draw()),
            0.3 * (1.0 + 0.03 * draw()),
            0.4 * (1.0 + 0.03 * draw()),
        );
        for theta2 in [0.0, 0.7, 1.9, PI, -2.3, -0.4] {
            let s = scene
                .with_parameters(&[
                    ("joints.A.initial.angle", theta2),
                    ("joints.B.anchor_a.x", 0.05 + (a - 0.1)),
                    ("joints.B.anchor_b.x", -0.175),
                    ("joints.C.anchor_a.x", -0.175 + b),
                    ("joints.C.anchor_b.x", -0.15 + c),
                    ("joints.D.anchor_b.x", d),
                ])
                .unwrap_or_else(|e| panic!("{e}"));
            let rocker = &s.model.bodies[2].pose;
            let (pin_c, pin_d) = (
                rocker.point(&nalgebra::Vector3::new(-0.15 + c, 0.0, 0.0)),
                rocker.point(&nalgebra::Vector3::new(-0.15, 0.0, 0.0)),
            );
            assert!((pin_d - nalgebra::Vector3::new(d, 0.0, 0.0)).norm() < 1e-12);
            let measured = (pin_c - pin_d).y.atan2((pin_c - pin_d).x);
            let exact = freudenstein(a, b, c, d, theta2);
            let err = ((measured - exact + PI).rem_euclid(2.0 * PI) - PI).abs();
            worst = worst.max(err);
            assert!(
                err < 1e-9,
                "a={a} b={b} c={c} d={d} θ2={theta2}: θ4 {measured} vs {exact} ({err:e})"
            );
            // the crank is where it was asked to be
            let crank = &s.model.bodies[0].pose;
            let tip = crank.point(&nalgebra::Vector3::new(-0.05 + a, 0.0, 0.0));
            assert!((tip.y.atan2(tip.x) - theta2).sin().abs() < 1e-12);
        }
    }
    eprintln!("largest rocker-angle error after assembly: {worst:e} rad");
}

/// A slider-crank in the x–z plane: crank radius r (`joints.pin.anchor_a.x`), rod l, the
/// slider on the x axis; the crank starts at `initial.angle` from +x.
const SLIDER_CRANK: &str = r#"
name: slider-crank-lengths
duration: 0.2 s
gravity: [0, 0, 0]
integrator: { h: 0.1 ms }
bodies:
  - { name: crank, mass: 0.1, shape: { box: { size: [0.05, 0.01, 0.01] } }, position: [0.025, 0, 0] }
  - { name: rod, mass: 0.2, shape: { box: { size: [0.12, 0.01, 0.01] } }, position: [0.11, 0, 0] }
  - { name: slider, mass: 0.1, shape: { box: { size: [0.03, 0.02, 0.02] } }, position: [0.17, 0, 0] }
joints:
  - { name: pivot, type: revolute, body_a: ground, body_b: crank, anchor_a: [0, 0, 0], anchor_b: [-0.025, 0, 0],
      axis_a: [0, 1, 0], axis_b: [0, 1, 0], drive: { velocity: 31.41592653589793 } }
  - { name: pin, type: revolute, body_a: crank, body_b: rod, anchor_a: [0.025, 0, 0], anchor_b: [-0.06, 0, 0],
      axis_a: [0, 1, 0], axis_b: [0, 1, 0] }
  - { name: wrist, type: revolute, body_a: rod, body_b: slider, anchor_a: [0.06, 0, 0], anchor_b: [0, 0, 0],
      axis_a: [0, 1, 0], axis_b: [0, 1, 0] }
  - { name: slide, type: prismatic, body_a: ground, body_b: slider, anchor: [0.17, 0, 0], axis: [1, 0, 0] }
probes:
  - { name: x_max, measure: { distance: { from: { body: ground }, to: { body: slider }, axis: [1, 0, 0] } }, reduce: max }
  - { name: x_min, measure: { distance: { from: { body: ground }, to: { body: slider }, axis: [1, 0, 0] } }, reduce: min }
"#;

#[test]
fn slider_crank_stroke_is_twice_the_crank_radius() {
    let scene = Scene::from_yaml(SLIDER_CRANK, "slider-crank").unwrap();
    for r in [0.02, 0.025, 0.031] {
        let crank = |angle: f64| {
            scene
                .with_parameters(&[
                    ("joints.pin.anchor_a.x", -0.025 + r),
                    ("joints.pivot.initial.angle", angle),
                ])
                .unwrap_or_else(|e| panic!("{e}"))
        };
        // the dead centres, assembled exactly: x = l + r and l − r
        let x = |s: &Scene| s.model.bodies[2].pose.x.x;
        let (top, bottom) = (crank(0.0), crank(PI));
        let l = 0.12;
        assert!((x(&top) - (l + r)).abs() < 1e-12, "{}", x(&top));
        assert!((x(&bottom) - (l - r)).abs() < 1e-12, "{}", x(&bottom));
        // one revolution at 5 rev/s from the top dead centre: the sampled extremes lie within
        // ½ r ω² (h/2)² of the dead centres
        let mut sim = crank(0.0);
        sim.params.h = 2e-5;
        let sim = sim.simulation().unwrap();
        let run = mc_study::probe::run::run_probes(
            sim,
            &scene.probes,
            &scene.curves,
            0.2,
            false,
            |_, _, _| {},
        );
        let (hi, lo) = (
            run.values[0].clone().unwrap(),
            run.values[1].clone().unwrap(),
        );
        let bound = 0.5 * r * (10.0 * PI).powi(2) * 1e-10 + 1e-12;
        assert!(
            ((hi - lo) - 2.0 * r).abs() < bound,
            "r = {r}: stroke {} vs {}",
            hi - lo,
            2.0 * r
        );
    }
}

#[test]
fn initial_velocities_follow_the_drive() {
    let scene = Scene::from_yaml(SLIDER_CRANK, "slider-crank").unwrap();
    // written at rest; the drive turns the crank at 10π rad/s from the top dead centre,
    // where the slider stands still and the crank pin moves at r ω along z
    let w = 10.0 * PI;
    let crank = &scene.model.bodies[0];
    let omega = crank.pose.p * crank.angular_velocity;
    assert!(
        (omega - nalgebra::Vector3::new(0.0, w, 0.0)).norm() < 1e-9 * w,
        "{omega}"
    );
    let slider = &scene.model.bodies[2];
    assert!(slider.velocity.norm() < 1e-9, "{}", slider.velocity);
    assert!(!scene.assembly.velocities_kept());
    // a rate that contradicts the drive is refused, naming the joint
    let e = scene
        .with_parameters(&[("joints.pivot.initial.rate", 1.0)])
        .unwrap_err();
    assert!(
        e.contains("joints[0].initial") && e.contains("contradicts the drive"),
        "{e}"
    );
}

#[test]
fn a_mechanism_that_cannot_close_names_its_joint() {
    let scene = Scene::from_yaml(FOUR_BAR, "four-bar").unwrap();
    // pivots 1 m apart: crank, coupler and rocker (0.75 m together) cannot reach
    let e = scene
        .with_parameters(&[("joints.D.anchor_b.x", 1.0)])
        .map(|s| s.assembly)
        .unwrap_err();
    assert!(
        e.contains("cannot be assembled")
            && (e.contains("joint `C`") || e.contains("joint `B`") || e.contains("joint `D`")),
        "{e}"
    );
    assert!(e.contains("four-bar:"), "the error names the file: {e}");
}

#[test]
fn written_poses_off_the_joints_are_pulled_onto_them_and_reported() {
    // the coupler written 5 mm off its pins: assembly moves it back, and says so
    let text = FOUR_BAR.replace(
        "position: [0.2021, 0.1421, 0]",
        "position: [0.2071, 0.1421, 0]",
    );
    let s = Scene::from_yaml(&text, "four-bar").unwrap();
    let moved = &s.assembly.bodies[1];
    assert_eq!(moved.body, "coupler");
    assert!(moved.translation > 1e-3, "{moved:?}");
    assert!(s.assembly.residual < 1e-12);
    let report = s.assembly.to_string();
    assert!(
        report.contains("coupler") && report.contains("moved"),
        "{report}"
    );
}

/// The bundled four-bar example with its pins made ideal (one word each) moves as the
/// closed form says: rocker angles between 93.5833° and 138.5904° (measured between the
/// frames), 104.9809° when the crank passes 90°.
#[test]
fn the_bundled_four_bar_with_ideal_pins_follows_the_closed_form() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("studies/four-bar-clearance/scene.yaml");
    let text = std::fs::read_to_string(path)
        .unwrap()
        .replace("type: revolute-clearance", "type: revolute")
        .replace(
            "  - { name: journal_C_offset, measure: { eccentricity: C }, reduce: mean, from: 0.5 s, to: 1 s, unit: um }\n",
            "",
        );
    let scene = Scene::from_yaml(&text, "four-bar ideal").unwrap();
    let sim = scene.simulation().unwrap();
    let run = mc_study::probe::run::run_probes(
        sim,
        &scene.probes,
        &scene.curves,
        1.0,
        false,
        |_, _, _| {},
    );
    let value = |name: &str| {
        let k = scene.probes.iter().position(|p| p.name == name).unwrap();
        run.values[k].clone().unwrap().to_degrees()
    };
    // Freudenstein's four-bar: a = 30, b = 110, c = 80, d = 120 mm
    let rocker = |theta2: f64| -> f64 {
        let (a, b, c, d) = (0.03, 0.11, 0.08, 0.12);
        freudenstein(a, b, c, d, theta2)
    };
    let range: Vec<f64> = (0..36000)
        .map(|i| rocker(i as f64 * 2.0 * PI / 36000.0))
        .collect();
    let (lo, hi) = range
        .iter()
        .fold((f64::MAX, f64::MIN), |(l, h), &x| (l.min(x), h.max(x)));
    let at_90 = rocker(PI / 2.0).to_degrees();
    for (name, exact) in [
        ("rocker_max", hi.to_degrees()),
        ("rocker_min", lo.to_degrees()),
        ("rocker_at_crank_90", at_90),
    ] {
        assert!(
            (value(name) - exact).abs() < 1e-4,
            "{name}: {} vs {exact}",
            value(name)
        );
    }
}
