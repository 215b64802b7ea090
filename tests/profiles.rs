//! Profiles in mechanisms: a roller follower on an eccentric cam against the analytic cam
//! law and its jump-off speed, a pin carried across a slot by a reversing load, and scene
//! errors that name the piece.

use mc_study::integrator::Simulation;
use mc_study::scene::Scene;
use mc_study::study::Subject;
use nalgebra::Vector3;

const G: f64 = 9.81;
/// Cam eccentricity, cam radius, roller radius (m).
const E: f64 = 0.01;
const R: f64 = 0.03;
const ROLLER: f64 = 0.01;

/// Follower lift (height of the roller centre) against cam angle θ: the roller centre stays
/// R + r from the cam centre (e cos θ, e sin θ).
fn lift(theta: f64) -> f64 {
    let (s, c) = theta.sin_cos();
    E * s + ((R + ROLLER).powi(2) - (E * c).powi(2)).sqrt()
}

/// d²y/dθ² of the lift, by central differences of the closed form.
fn lift_curvature(theta: f64) -> f64 {
    let d = 1e-4;
    (lift(theta + d) - 2.0 * lift(theta) + lift(theta - d)) / (d * d)
}

/// A cam turning about the world z axis at `omega`, a roller follower on a vertical
/// prismatic joint above it, held down by gravity alone; one revolution.
fn cam_follower(omega: f64) -> Scene {
    let y0 = lift(0.0);
    let yaml = format!(
        r#"
name: cam-follower
duration: {duration}
gravity: [0, -9.81, 0]
integrator: {{ h: 0.5 ms, scheme: combined-projection }}
bodies:
  - name: cam
    mass: 1
    shape: {{ cylinder: {{ radius: {R}, length: 0.01 }} }}
  - name: follower
    mass: 0.1
    shape: {{ cylinder: {{ radius: {ROLLER}, length: 0.01 }} }}
    position: [0, {y0}, 0]
    velocity: [0, {v0}, 0]
joints:
  - {{ name: shaft, type: revolute, body_a: ground, body_b: cam, anchor: [0, 0, 0], axis: [0, 0, 1], drive: {{ velocity: {omega} }} }}
  - {{ name: guide, type: prismatic, body_a: ground, body_b: follower, anchor: [0, {y0}, 0], axis: [0, 1, 0] }}
contacts:
  - name: roller
    body: follower
    shape: {{ cylinder: {{ radius: {ROLLER}, length: 0.01, axis: [0, 0, 1] }} }}
    against: cam
    against_shape:
      profile:
        thickness: 0.01
        start: [{start}, 0]
        path:
          - arc: {{ to: [{start}, 0], center: [{E}, 0] }}
"#,
        duration = std::f64::consts::TAU / omega,
        v0 = omega * E,
        start = E + R,
    );
    Scene::from_yaml(&yaml, "cam-follower").unwrap_or_else(|e| panic!("{e}"))
}

/// Cam angle (from its body x axis) and follower height.
fn cam_angle_and_lift(sim: &Simulation) -> (f64, f64) {
    let x = sim.state.poses[0].p * Vector3::x();
    (x.y.atan2(x.x), sim.state.poses[1].x.y)
}

/// The largest distance of the follower above the cam law over one revolution.
fn largest_lift_error(omega: f64) -> (f64, f64) {
    let mut sim = cam_follower(omega).simulation().unwrap();
    let (mut above, mut below) = (0.0f64, 0.0f64);
    let end = std::f64::consts::TAU / omega;
    sim.run_until(end, |s, _| {
        let (theta, y) = cam_angle_and_lift(s);
        let err = y - lift(theta);
        above = above.max(err);
        below = below.min(err);
    })
    .unwrap();
    assert_eq!(sim.stats.projection_failures, 0);
    eprintln!(
        "omega {omega}: {below:e} … {above:e}, steps {}",
        sim.stats.steps
    );
    (above, below)
}

/// At low speed the roller follows the cam law to 1e-6 of the stroke over a revolution.
#[test]
fn a_roller_follower_lifts_by_the_cam_law() {
    let (above, below) = largest_lift_error(1.0);
    let stroke = 2.0 * E;
    assert!(
        above.max(-below) < 1e-6 * stroke,
        "lift error {below:e} … {above:e} m"
    );
}

/// The roller leaves the cam where the contact force m (g + ω² y''(θ)), predicted from the
/// analytic lift, would turn negative: it stays on at 0.97 of that speed and jumps at 1.03.
#[test]
fn the_follower_jumps_off_where_the_predicted_contact_force_reaches_zero() {
    let steepest = (0..3600)
        .map(|k| -lift_curvature(k as f64 / 3600.0 * std::f64::consts::TAU))
        .fold(f64::MIN, f64::max);
    let critical = (G / steepest).sqrt();
    let (above, _) = largest_lift_error(0.97 * critical);
    assert!(
        above < 1e-9,
        "left the cam below the critical speed: {above:e} m"
    );
    let (above, _) = largest_lift_error(1.03 * critical);
    assert!(
        above > 1e-5,
        "stayed on above the critical speed: {above:e} m"
    );
}

/// A pin of radius 5 mm with 0.1 mm of radial clearance in a slot cut in the frame (a hole
/// profile: two flats and two half circles), sliding along it while a sideways load
/// reverses: it rests on one flank, then crosses to the other, and never enters either.
#[test]
fn a_pin_in_a_slot_changes_flank_when_the_load_reverses() {
    let (r, c) = (0.005, 1e-4);
    let w = r + c;
    let yaml = format!(
        r#"
name: pin-in-slot
duration: 0.5
plane: xy
gravity: [0, 0, 0]
integrator: {{ h: 1 ms, scheme: combined-projection }}
bodies:
  - name: pin
    mass: 0.1
    shape: {{ cylinder: {{ radius: {r}, length: 0.01 }} }}
    position: [0.05, 0, 0]
    velocity: [0.1, 0, 0]
forces:
  - load: {{ body: pin, force_table: [[0, 0, -1, 0], [0.2, 0, -1, 0], [0.2001, 0, 1, 0], [1, 0, 1, 0]] }}
contacts:
  - name: slot
    body: pin
    shape: {{ cylinder: {{ radius: {r}, length: 0.01 }} }}
    e: 0.5
    against_shape:
      profile:
        thickness: 0.01
        solid: outside
        start: [0, -{w}]
        path:
          - line: [0.2, -{w}]
          - arc: {{ to: [0.2, {w}], center: [0.2, 0] }}
          - line: [0, {w}]
          - arc: {{ to: [0, -{w}], center: [0, 0] }}
"#
    );
    let scene = Scene::from_yaml(&yaml, "pin-in-slot").unwrap_or_else(|e| panic!("{e}"));
    let mut sim = scene.simulation().unwrap();
    sim.run_until(0.19, |_, _| {}).unwrap();
    let y = sim.state.poses[0].x.y;
    assert!((y + c).abs() < 1e-10, "on the lower flank: y = {y:e}");
    sim.run_until(0.5, |_, _| {}).unwrap();
    let y = sim.state.poses[0].x.y;
    assert!((y - c).abs() < 1e-10, "on the upper flank: y = {y:e}");
    assert!((sim.state.poses[0].x.x - 0.1).abs() < 1e-9);
    eprintln!("slot: y {y:e}, penetration {:e}", sim.stats.max_penetration);
    assert!(
        sim.stats.max_penetration <= 1e-10,
        "{:e}",
        sim.stats.max_penetration
    );
    assert_eq!(sim.stats.projection_failures, 0);
}

/// A profile's errors name the file, the line and the field of the piece at fault.
#[test]
fn bad_profiles_are_refused_with_the_piece_and_line() {
    let scene = |path: &str, extra: &str| {
        format!(
            "name: bad\nduration: 1\nbodies:\n  - {{ name: pin, mass: 1, inertia: [1, 1, 1] }}\ncontacts:\n  - body: pin\n    shape: {{ point: {{ position: [0, 0, 0] }} }}\n    against_shape:\n      profile:\n        thickness: 0.01\n{extra}        start: [0, 0]\n        path:\n{path}"
        )
    };
    let cases = [
        (
            scene(
                "          - line: [1, 0]\n          - line: [1, 0]\n",
                "        solid: left\n",
            ),
            15,
            "path[1]",
            "zero-length segment",
        ),
        (
            scene(
                "          - arc: { to: [2, 0], center: [1.2, 0.5] }\n",
                "        solid: left\n",
            ),
            14,
            "path[0]",
            "inconsistent radius",
        ),
        (
            scene("          - line: [1, 0]\n", ""),
            9,
            "profile",
            "closed profile",
        ),
        (
            scene(
                "          - arc: { to: [1, 0], center: [0, 1], direction: up }\n",
                "        solid: left\n",
            ),
            14,
            "arc.direction",
            "expected ccw or cw",
        ),
        (
            scene("          - line: [1, 0, 0]\n", "        solid: left\n"),
            14,
            "path[0].line",
            "2 components",
        ),
        // a bow tie: its second and fourth sides cross at (0.5, 0.5)
        (
            scene(
                "          - line: [1, 0]\n          - line: [0, 1]\n          - line: [1, 1]\n          - line: [0, 0]\n",
                "        solid: inside\n",
            ),
            17,
            "path[3]",
            "the profile crosses itself: piece 1 and piece 3 intersect near (0.500000, 0.500000)",
        ),
    ];
    for (yaml, line, field, message) in cases {
        let e = Scene::from_yaml(&yaml, "bad.yaml").expect_err(&yaml);
        assert_eq!(e.line, Some(line), "{e}");
        assert!(e.field.contains(field), "{e}");
        assert!(e.message.contains(message), "{e}");
        assert!(e.to_string().contains("bad.yaml"), "{e}");
    }
}

/// The bundled cam study: its outputs are the cam law's stroke and the margin of the
/// roller's contact force, m (g + ω² y''), whose minimum is not cautioned (a normal force
/// an impact can only raise), while its maximum is.
#[test]
fn the_bundled_cam_reads_the_stroke_and_the_force_margin_of_the_cam_law() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/cam-follower/scene.yaml");
    let text = std::fs::read_to_string(&path).unwrap();
    let scene = Scene::from_yaml(&text, "cam-follower").unwrap();
    let probe = |name: &str| scene.probes.iter().find(|p| p.name == name).unwrap();
    assert!(probe("roller_min_force").caution.is_none());
    let peak = text.replace("reduce: min", "reduce: max");
    let peaked = Scene::from_yaml(&peak, "cam-follower").unwrap();
    assert!(peaked.probes.iter().any(|p| p.caution.is_some()));

    let subject = Subject::from_yaml(&text, "cam-follower").unwrap();
    let n = subject.outputs().len();
    let o = subject.run(&[], &(0..n).collect::<Vec<_>>());
    assert!(o.error.is_none(), "{:?}", o.error);
    // written 39.3 mm up; the top of the cam law is e + R + r = 50 mm, which the steps
    // (h = 0.2 ms) sample to within ½ e (ω h)² = 1.5e-7 m
    let omega: f64 = 27.8;
    let stroke = o.outputs[0];
    assert!((stroke - (0.05 - 0.0393)).abs() < 2e-7, "{stroke}");
    // the force margin over the top: the analytic lift's smallest m (g + ω² y'')
    let margin = (0..36000)
        .map(|k| {
            0.1 * (G + omega * omega * lift_curvature(k as f64 / 36000.0 * std::f64::consts::TAU))
        })
        .fold(f64::MAX, f64::min);
    let min_force = o.outputs[1];
    eprintln!("stroke {stroke}, min force {min_force} N against {margin} N");
    assert!(
        (min_force - margin).abs() < 1e-5,
        "{min_force} against {margin}"
    );
}

/// Profile on profile: a 40 × 10 mm bar (a closed rectangle) dropped flat onto a step of
/// the frame (an open profile, material below): it lands, stays flat and the step
/// carries its weight.
#[test]
fn a_profile_rests_on_a_profile() {
    let yaml = r#"
name: bar-on-step
duration: 0.5
plane: xy
gravity: [0, -9.81, 0]
integrator: { h: 1 ms, scheme: combined-projection, solver: { tolerance: 1e-12 } }
bodies:
  - name: bar
    mass: 0.2
    shape: { box: { size: [40 mm, 10 mm, 10 mm] } }
    position: [5 mm, 5.2 mm, 0]
contacts:
  - name: step
    body: bar
    shape:
      profile:
        thickness: 10 mm
        start: [-20 mm, -5 mm]
        path:
          - line: [20 mm, -5 mm]
          - line: [20 mm, 5 mm]
          - line: [-20 mm, 5 mm]
          - line: [-20 mm, -5 mm]
    against_shape:
      profile:
        thickness: 10 mm
        solid: right
        start: [-30 mm, 0]
        path:
          - line: [30 mm, 0]
          - line: [30 mm, -10 mm]
probes:
  - { name: weight, measure: { contact_force: step }, reduce: mean, from: 0.3 s }
"#;
    let scene = Scene::from_yaml(yaml, "bar-on-step").unwrap_or_else(|e| panic!("{e}"));
    let mut sim = scene.simulation().unwrap();
    sim.run_until(0.5, |_, _| {}).unwrap();
    let pose = sim.state.poses[0];
    let tilt = (pose.p * Vector3::x()).y.abs();
    assert!(tilt < 1e-9, "tilt {tilt:e}");
    assert!((pose.x.y - 0.005).abs() < 1e-10, "{}", pose.x.y);
    assert!(
        sim.stats.max_penetration < 1e-10,
        "{:e}",
        sim.stats.max_penetration
    );
    let subject = Subject::from_yaml(yaml, "bar-on-step").unwrap();
    let o = subject.run(&[], &[0]);
    assert!(
        (o.outputs[0] / (0.2 * G) - 1.0).abs() < 1e-9,
        "{} N",
        o.outputs[0]
    );
}

/// Drawings show a closed profile as a polygon along its outline (arcs sampled) and an
/// open one as a polyline.
#[test]
fn drawings_show_profiles() {
    use mc_study::single_run::drawing::{svg, Snapshot, View};
    let scene = cam_follower(1.0);
    let poses: Vec<_> = scene.model.bodies.iter().map(|b| b.pose).collect();
    let text = svg(&scene.model, &[Snapshot { t: 0.0, poses }], View::Xy, "cam");
    // the cam: a closed polygon of the 64-sided sampling of its circle, 30 mm in radius
    let cam = text
        .lines()
        .filter(|l| l.starts_with("<polygon"))
        .map(|l| l.matches(',').count())
        .max()
        .unwrap();
    assert!(cam >= 64, "{cam} points");
    let open = Scene::from_yaml(
        "duration: 1\nbodies:\n  - { name: b, mass: 1, inertia: [1, 1, 1] }\ncontacts:\n  - body: b\n    shape: { point: { position: [0, 0, 0] } }\n    against_shape: { profile: { thickness: 0.01, solid: right, start: [0, 0], path: [ { line: [0.1, 0] }, { arc: { to: [0.2, 0], center: [0.15, 0] } } ] } }\n",
        "open",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let poses: Vec<_> = open.model.bodies.iter().map(|b| b.pose).collect();
    let text = svg(&open.model, &[Snapshot { t: 0.0, poses }], View::Xy, "open");
    assert!(text.contains("<polyline fill=\"none\""), "{text}");
}
