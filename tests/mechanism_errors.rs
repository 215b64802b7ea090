//! Bad input to the user's-own-mechanism features: parameter paths (wrong unit, out of
//! range, unknown name), joint initial conditions, and the probe measures. Each error names
//! the field (and its line where the scene has one).

use mc_study::scene::Scene;

/// A crank on a driven revolute joint, a rod on a clearance joint, a slider on a prismatic
/// joint, a spring and a load: one of each kind the checks below need.
const SCENE: &str = "name: errors
duration: 10 ms
gravity: [0, 0, -9.81]
integrator: { h: 0.1 ms }
bodies:
  - { name: crank, mass: 0.1, shape: { box: { size: [0.05, 0.01, 0.01] } }, position: [0.025, 0, 0] }
  - { name: rod, mass: 0.2, shape: { box: { size: [0.12, 0.01, 0.01] } }, position: [0.11, 0, 0] }
  - { name: slider, mass: 0.1, shape: { box: { size: [0.03, 0.02, 0.02] } }, position: [0.17, 0, 0] }
joints:
  - { name: pivot, type: revolute, body_a: ground, body_b: crank, anchor: [0, 0, 0], axis: [0, 1, 0],
      drive: { velocity: 10 rad/s } }
  - { name: pin, type: revolute-clearance, body_a: rod, body_b: crank, anchor: [0.05, 0, 0], axis: [0, 1, 0],
      clearance: 0.2 mm, journal_radius: 5 mm, bore_length: 10 mm, mu: 0.1 }
  - { name: wrist, type: revolute, body_a: rod, body_b: slider, anchor: [0.17, 0, 0], axis: [0, 1, 0] }
  - { name: slide, type: prismatic, body_a: ground, body_b: slider, anchor: [0.17, 0, 0], axis: [1, 0, 0] }
forces:
  - name: return
    spring: { body_a: ground, point_a: [0.3, 0, 0], body_b: slider, stiffness: 100 N/m }
probes:
  - { name: angle, measure: { angle: pivot } }
";

fn scene() -> Scene {
    Scene::from_yaml(SCENE, "scene.yaml").unwrap_or_else(|e| panic!("{e}"))
}

/// The error of `--set` (PATH=VALUE).
fn set_error(setting: &str) -> String {
    scene()
        .apply_setting(setting)
        .err()
        .unwrap_or_else(|| panic!("accepted `{setting}`"))
}

#[test]
fn the_scene_is_accepted_and_each_new_path_is_set() {
    let mut s = scene();
    for setting in [
        "joints.pin.clearance=0.1mm",
        "joints.pin.initial.eccentricity.x=0.05mm",
        "joints.pivot.initial.angle=30deg",
        "joints.slide.anchor.y=0",
        "forces.return.spring.stiffness=200N/m",
        "forces.return.spring.rest_length=0.1m",
        "joints.pivot.drive.velocity=20rad/s",
        "bodies.rod.shape.box.size.x=121mm",
        "integrator.h=50us",
        "duration=5ms",
    ] {
        s.apply_setting(setting)
            .unwrap_or_else(|e| panic!("{setting}: {e}"));
    }
    assert_eq!(s.params.h, 5e-5);
    assert_eq!(s.duration, 5e-3);
    assert!((s.model.clearance_joints[0].clearance - 1e-4).abs() < 1e-18);
}

#[test]
fn a_wrong_unit_names_both_dimensions() {
    let e = set_error("joints.pin.clearance=3N");
    assert!(e.contains("a length") && e.contains("a force"), "{e}");
    let e = set_error("joints.pivot.initial.angle=5mm");
    assert!(e.contains("dimensionless") && e.contains("a length"), "{e}");
    let e = set_error("forces.return.spring.stiffness=3N*m");
    assert!(e.contains("a stiffness"), "{e}");
}

#[test]
fn a_value_out_of_range_names_the_field_and_the_value() {
    let e = set_error("joints.pin.clearance=-1mm");
    assert!(
        e.contains("joints.pin.clearance = -0.001")
            && e.contains("`joints[1].clearance` must be ≥ 0"),
        "{e}"
    );
    let e = set_error("forces.return.spring.stiffness=-5");
    assert!(
        e.contains("`forces[0].spring.stiffness` must be ≥ 0"),
        "{e}"
    );
    let e = set_error("joints.pin.initial.eccentricity.x=0.3mm");
    assert!(
        e.contains("joints[1].initial.eccentricity") && e.contains("shorter than the clearance"),
        "{e}"
    );
    let e = set_error("joints.pin.flange_radius=5.1mm");
    assert!(
        e.contains("joints[1].flange_radius") && e.contains("twice the clearance"),
        "{e}"
    );
    let e = set_error("integrator.h=0");
    assert!(e.contains("`integrator.h` must be positive"), "{e}");
}

#[test]
fn an_unknown_name_lists_the_nearest_paths() {
    let e = set_error("joints.pinn.clearance=0.1mm");
    assert!(
        e.contains("unknown parameter path `joints.pinn.clearance`")
            && e.contains("joints.pin.clearance"),
        "{e}"
    );
    let e = set_error("forces.returns.spring.stiffness=5");
    assert!(e.contains("forces.return.spring.stiffness"), "{e}");
    let e = set_error("joints.pivot.clearance=0.1mm");
    assert!(e.contains("ideal revolute joint"), "{e}");
    let e = set_error("joints.slide.initial.angle=1");
    assert!(e.contains("unknown parameter path"), "{e}");
    let e = set_error("joints.pivot.anchor.w=1");
    assert!(e.contains("`anchor` has the components x, y, z"), "{e}");
    let e = set_error("joints.pivot.drive.effort=1");
    assert!(e.contains("unknown parameter path"), "{e}");
}

/// The scene with `probe` (one YAML line) added; its error.
fn probe_error(probe: &str) -> String {
    let text = format!("{SCENE}  - {probe}\n");
    match Scene::from_yaml(&text, "scene.yaml") {
        Ok(_) => panic!("accepted {probe}"),
        Err(e) => e.to_string(),
    }
}

/// The line of the added probe.
fn probe_line() -> String {
    format!("scene.yaml:{}:", SCENE.lines().count() + 1)
}

#[test]
fn each_measure_refuses_what_it_cannot_measure() {
    for (probe, field, what) in [
        (
            "{ name: p, measure: { angle: slide } }",
            "probes[1].measure.angle",
            "measure its `displacement`",
        ),
        (
            "{ name: p, measure: { displacement: pivot } }",
            "probes[1].measure.displacement",
            "measure its `angle`",
        ),
        (
            "{ name: p, measure: { angle: nowhere } }",
            "probes[1].measure.angle",
            "unknown joint `nowhere` (joints: pivot, wrist, slide, pin)",
        ),
        (
            "{ name: p, measure: { reaction: nowhere } }",
            "probes[1].measure.reaction",
            "unknown joint",
        ),
        (
            "{ name: p, measure: { drive_effort: wrist } }",
            "probes[1].measure.drive_effort",
            "has no drive",
        ),
        (
            "{ name: p, measure: { drive_effort: pin } }",
            "probes[1].measure.drive_effort",
            "has no drive",
        ),
        (
            "{ name: p, measure: { eccentricity: slide } }",
            "probes[1].measure.eccentricity",
            "only a revolute joint, with or without clearance,",
        ),
        (
            "{ name: p, measure: { velocity: { body: ground } } }",
            "probes[1].measure.velocity.body",
            "the ground does not move",
        ),
        (
            "{ name: p, measure: { angular_velocity: wheel } }",
            "probes[1].measure.angular_velocity",
            "unknown body `wheel`",
        ),
        (
            "{ name: p, measure: { velocity: { body: rod }, angle_from: [1, 0, 0] } }",
            "probes[1].measure.angle_from",
            "a joint axis",
        ),
        (
            "{ name: p, measure: { reaction: pin, axis: [1, 0, 0], angle_from: [1, 0, 0] } }",
            "probes[1].measure.axis",
            "not both",
        ),
        (
            "{ name: p, measure: { reaction: pin, frame: rod } }",
            "probes[1].measure.frame",
            "goes with `axis`",
        ),
        (
            "{ name: p, measure: { gap: pin, axis: [1, 0, 0] } }",
            "probes[1].measure",
            "belong to vector quantities",
        ),
        (
            "{ name: p, measure: { reaction: pin, axis: [0, 0, 0] } }",
            "probes[1].measure.axis",
            "zero vector",
        ),
        (
            "{ name: p, measure: { gap: pin, angle: pivot } }",
            "probes[1].measure",
            "exactly one of",
        ),
        (
            "{ name: p, measure: { impulse: pin }, reduce: mean, from: 1 ms, to: 2 ms }",
            "probes[1].reduce",
            "use `sum`",
        ),
        (
            "{ name: p, measure: { contact_force: pin }, reduce: sum }",
            "probes[1].reduce",
            "goes with `impulse`",
        ),
        (
            "{ name: p, measure: { reaction: pin }, reduce: median }",
            "probes[1].reduce",
            "unknown reduction `median`",
        ),
        (
            "{ name: p, measure: { reaction: pin }, unit: mm }",
            "probes[1].unit",
            "a length",
        ),
        (
            "{ name: p, measure: { angle: pivot }, unit: furlong }",
            "probes[1].unit",
            "unknown unit `furlong`",
        ),
        (
            "{ name: wall_ms, measure: { angle: pivot } }",
            "probes[1].name",
            "the results' own columns",
        ),
        (
            "{ name: sample_id, measure: { angle: pivot } }",
            "probes[1].name",
            "the results' own columns",
        ),
    ] {
        let e = probe_error(probe);
        assert!(e.starts_with(&probe_line()), "{probe}: wrong line in {e}");
        assert!(
            e.contains(&format!("`{field}`")),
            "{probe}: no `{field}` in {e}"
        );
        assert!(e.contains(what), "{probe}: no `{what}` in {e}");
    }
}

#[test]
fn a_peak_of_a_force_is_cautioned_a_window_mean_is_not() {
    let text = format!(
        "{SCENE}  - {{ name: peak, measure: {{ reaction: pin }}, reduce: max }}\n  - {{ name: mean, measure: {{ reaction: pin }}, reduce: mean }}\n  - {{ name: impact, measure: {{ impulse: pin }}, reduce: max }}\n"
    );
    let s = Scene::from_yaml(&text, "scene.yaml").unwrap();
    let caution = |name: &str| {
        s.probes
            .iter()
            .find(|p| p.name == name)
            .unwrap()
            .caution
            .clone()
    };
    let c = caution("peak").expect("a caution");
    assert!(c.contains("1/h") && c.contains("impulse"), "{c}");
    assert!(caution("mean").is_none());
    assert!(caution("impact").is_none());
}

#[test]
fn initial_conditions_that_do_not_fit_the_joint_are_refused() {
    for (from, to, field, what) in [
        (
            "axis: [1, 0, 0] }",
            "axis: [1, 0, 0], initial: { angle: 1 } }",
            "joints[3].initial.angle",
            "a prismatic joint starts at a `position`",
        ),
        (
            "drive: { velocity: 10 rad/s } }",
            "drive: { velocity: 10 rad/s }, initial: { rate: 3 } }",
            "joints[0].initial",
            "contradicts the drive's velocity",
        ),
        (
            "mu: 0.1 }",
            "mu: 0.1, initial: { angle: 1 } }",
            "joints[1].initial",
            "starts with its journal at an `eccentricity`",
        ),
    ] {
        assert!(SCENE.contains(from), "{from}");
        let e = Scene::from_yaml(&SCENE.replacen(from, to, 1), "scene.yaml")
            .err()
            .unwrap_or_else(|| panic!("accepted {to}"))
            .to_string();
        assert!(e.contains(&format!("`{field}`")) && e.contains(what), "{e}");
    }
}
