//! Bad scene input: every error names the field and the line, and the CLI exits non-zero.

use mc_study::scene::Scene;

const GOOD_BALL: &str = "duration: 1 s
bodies:
  - name: ball
    mass: 1 kg
    shape: { sphere: { radius: 0.1 m } }
    position: [0, 0, 1 m]
contacts:
  - name: floor
    body: ball
    shape: { sphere: { radius: 0.1 m } }
    against: ground
    against_shape: { plane: { normal: [0, 0, 1] } }
    mu: 0.2
    e: 0.5
";

/// Replaces `from` by `to` in the good scene and returns the error.
fn error_of(from: &str, to: &str) -> String {
    assert!(GOOD_BALL.contains(from), "test typo: {from}");
    refused(&GOOD_BALL.replacen(from, to, 1), to)
}

/// The error of the scene `text`, which `what` makes bad.
fn refused(text: &str, what: &str) -> String {
    match Scene::from_yaml(text, "scene.yaml") {
        Ok(_) => panic!("accepted bad input: {what}"),
        Err(e) => e.to_string(),
    }
}

fn expect(from: &str, to: &str, field: &str, line: u32) {
    let e = error_of(from, to);
    assert!(
        e.starts_with(&format!("scene.yaml:{line}:")),
        "wrong line in: {e}"
    );
    assert!(e.contains(field), "field `{field}` not named in: {e}");
}

#[test]
fn the_good_scene_is_accepted() {
    let s = Scene::from_yaml(GOOD_BALL, "scene.yaml").unwrap();
    assert_eq!(s.model.bodies[0].mass, 1.0);
    assert_eq!(s.model.contacts[0].mu, 0.2);
}

#[test]
fn unknown_field() {
    expect(
        "    position",
        "    colour: red\n    position",
        "unknown field `colour`",
        6,
    );
}

#[test]
fn settle_names_an_unknown_contact_or_a_negative_damping() {
    expect(
        "contacts:",
        "settle: { until: 1 ms, friction: [flor] }\ncontacts:",
        "`settle.friction[0]` unknown contact or joint `flor`",
        7,
    );
    expect(
        "contacts:",
        "settle:\n  until: 1 ms\n  damping: -5 Hz\ncontacts:",
        "settle.damping",
        9,
    );
    expect(
        "contacts:",
        "settle: { until: 0 s }\ncontacts:",
        "settle.until",
        7,
    );
    expect(
        "contacts:",
        "settle: { until: 1 ms, h: 0 s }\ncontacts:",
        "settle.h",
        7,
    );
    expect(
        "contacts:",
        "settle: { until: 1 ms, tolerance: -1e-8 }\ncontacts:",
        "settle.tolerance",
        7,
    );
}

#[test]
fn negative_mass() {
    expect("mass: 1 kg", "mass: -1 kg", "bodies[0].mass", 4);
}

#[test]
fn non_positive_definite_inertia() {
    expect(
        "    shape: { sphere: { radius: 0.1 m } }\n    position",
        "    inertia: [1, -2, 3]\n    position",
        "bodies[0].inertia",
        5,
    );
    expect(
        "    shape: { sphere: { radius: 0.1 m } }\n    position",
        "    inertia: [1, 0, 0, 0.5, 1, 0, 0, 0, 1]\n    position",
        "symmetric positive definite",
        5,
    );
}

#[test]
fn non_positive_time_step() {
    expect(
        "duration: 1 s\n",
        "duration: 1 s\nintegrator:\n  h: 0\n",
        "integrator.h",
        3,
    );
    expect(
        "duration: 1 s\n",
        "duration: 1 s\nintegrator:\n  h: -1 ms\n",
        "integrator.h",
        3,
    );
}

#[test]
fn restitution_outside_the_unit_interval() {
    expect("e: 0.5", "e: 1.5", "contacts[0].e", 14);
    expect("e: 0.5", "e: -0.1", "contacts[0].e", 14);
}

#[test]
fn negative_friction() {
    expect("mu: 0.2", "mu: -0.2", "contacts[0].mu", 13);
}

#[test]
fn unknown_body_name() {
    expect(
        "against: ground",
        "against: table",
        "unknown body `table`",
        11,
    );
    expect("    body: ball", "    body: bal", "contacts[0].body", 9);
}

#[test]
fn wrong_unit_dimension_and_bad_theta() {
    expect(
        "radius: 0.1 m } }\n    position",
        "radius: 0.1 ms } }\n    position",
        "a length",
        5,
    );
    expect(
        "duration: 1 s\n",
        "duration: 1 s\nintegrator:\n  theta: 0.3\n",
        "integrator.theta",
        3,
    );
}

#[test]
fn locate_impacts_must_be_a_boolean() {
    expect(
        "duration: 1 s\n",
        "duration: 1 s\nintegrator:\n  locate_impacts: often\n",
        "invalid boolean",
        3,
    );
}

#[test]
fn yaml_syntax_error_names_the_line() {
    let e = error_of("    mass: 1 kg", "    mass: [1 kg");
    assert!(e.starts_with("scene.yaml:"), "{e}");
}

mod cli {
    use std::process::Command;

    fn mc_study(args: &[&str]) -> std::process::Output {
        Command::new(env!("CARGO_BIN_EXE_mc-study"))
            .args(args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap()
    }

    #[test]
    fn simulate_writes_csv_and_parquet_and_prints_diagnostics() {
        let dir = std::env::temp_dir().join(format!("mc-study-cli-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for ext in ["csv", "parquet"] {
            let out = dir.join(format!("ball.{ext}"));
            let o = mc_study(&[
                "simulate",
                "studies/bouncing-ball/scene.yaml",
                "--out",
                out.to_str().unwrap(),
            ]);
            let stdout = String::from_utf8_lossy(&o.stdout);
            assert!(
                o.status.success(),
                "{stdout}{}",
                String::from_utf8_lossy(&o.stderr)
            );
            for key in [
                "steps            10000",
                "max penetration",
                "solver failures  0",
                "wall time",
            ] {
                assert!(stdout.contains(key), "missing `{key}` in:\n{stdout}");
            }
            let meta = std::fs::metadata(&out).unwrap();
            assert!(meta.len() > 1000, "{ext} output is {} bytes", meta.len());
        }
        let csv = std::fs::read_to_string(dir.join("ball.csv")).unwrap();
        let header = csv.lines().next().unwrap();
        assert!(
            header.starts_with("t,energy,ball.x,ball.y,ball.z,ball.qw"),
            "{header}"
        );
        assert!(header.contains("floor.gap") && header.contains("floor.pn"));
        assert_eq!(
            csv.lines().count(),
            1 + 1001,
            "initial row + every 10th of 10000 steps"
        );
        std::fs::remove_dir_all(&dir).ok();
    }

    /// `paths` shows a value the scene leaves out as the default that applies, or where
    /// it comes from, in parentheses.
    #[test]
    fn paths_show_what_a_left_out_value_stands_for() {
        let o = mc_study(&["paths", "studies/c60/scene.yaml"]);
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let value = |path: &str| {
            let line = stdout
                .lines()
                .find(|l| l.split_whitespace().next() == Some(path))
                .unwrap_or_else(|| panic!("no `{path}` in:\n{stdout}"));
            line.split_whitespace()
                .skip(2)
                .collect::<Vec<_>>()
                .join(" ")
        };
        assert_eq!(value("integrator.h"), "4e-6");
        assert_eq!(value("refine.approach"), "2e-5");
        assert_eq!(value("integrator.theta"), "(0.5)");
        assert_eq!(value("integrator.newton.tolerance"), "(1e-10)");
        assert_eq!(value("joints.J1.rim_points"), "(4)");
        assert_eq!(value("bodies.handle.velocity.x"), "(0)");
        assert!(value("joints.J1.flange_radius").starts_with("(1.5 × journal_radius"));
        assert!(!stdout.contains("default"), "{stdout}");
    }

    /// `--set` overrides a parameter as a study would (the probes change accordingly), a
    /// wrong path or unit is refused naming it, and `--svg` draws one panel per snapshot.
    #[test]
    fn simulate_sets_parameters_prints_probes_and_draws() {
        let dir = std::env::temp_dir().join(format!("mc-study-draw-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let svg = dir.join("ball.svg");
        let o = mc_study(&[
            "simulate",
            "studies/bouncing-ball/scene.yaml",
            "--duration",
            "1",
            "--set",
            "bodies.ball.position.z=2.1 m",
            "--svg",
            svg.to_str().unwrap(),
            "--snapshots",
            "0s,200ms,1s",
        ]);
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(
            o.status.success(),
            "{stdout}{}",
            String::from_utf8_lossy(&o.stderr)
        );
        // dropped from 2.1 m (gap 2 m) the first impact comes at sqrt(2·2/9.81) = 0.6386 s
        let line = stdout
            .lines()
            .find(|l| l.contains("first_impact_time"))
            .unwrap_or_else(|| panic!("{stdout}"));
        let t: f64 = line.split_whitespace().nth(1).unwrap().parse().unwrap();
        assert!((t - (4.0f64 / 9.81).sqrt()).abs() < 2e-3, "{line}");
        let drawing = std::fs::read_to_string(&svg).unwrap();
        assert!(drawing.starts_with("<svg") && drawing.trim_end().ends_with("</svg>"));
        for panel in ["t = 0.000 ms", "t = 200.000 ms", "t = 1000.000 ms"] {
            assert!(drawing.contains(panel), "no panel `{panel}`");
        }
        // the ball's contact sphere (r = 0.1 m = 100 mm) is drawn in each panel
        assert_eq!(drawing.matches(r#"r="100.0000""#).count(), 3, "{drawing}");
        for (set, expect) in [
            ("bodies.nope.mass=1", "nope"),
            ("bodies.ball.mass=3 mm", "a mass"),
            ("bodies.ball.mass", "PATH=VALUE"),
            // a bare number for a length: 0.1 would be 100 mm
            (
                "bodies.ball.shape.sphere.radius=0.1",
                "`bodies.ball.shape.sphere.radius` is a length (e.g. mm): write its unit, e.g. `bodies.ball.shape.sphere.radius=0.1 m`",
            ),
        ] {
            let o = mc_study(&["simulate", "studies/bouncing-ball/scene.yaml", "--set", set]);
            let err = String::from_utf8_lossy(&o.stderr);
            assert!(!o.status.success() && err.contains(expect), "{set}: {err}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn bad_scene_exits_nonzero_with_the_field_and_line() {
        let dir = std::env::temp_dir().join(format!("mc-study-bad-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("bad.yaml");
        std::fs::write(&path, super::GOOD_BALL.replace("mass: 1 kg", "mass: -1 kg")).unwrap();
        let o = mc_study(&["simulate", path.to_str().unwrap()]);
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains("bad.yaml:4:")
                && err.contains("bodies[0].mass")
                && err.contains("must be positive"),
            "{err}"
        );
        assert!(!err.contains("Stack backtrace"), "{err}");
        let o = mc_study(&["simulate", "no/such/scene.yaml"]);
        assert!(!o.status.success());
        assert!(String::from_utf8_lossy(&o.stderr).contains("cannot read the scene file"));
        std::fs::remove_dir_all(&dir).ok();
    }
}

const PENDULUM: &str = "duration: 1 s
bodies:
  - name: bar
    mass: 1 kg
    shape: { box: { size: [1 m, 20 mm, 20 mm] } }
    position: [0.5 m, 0, 0]
joints:
  - name: pivot
    type: revolute
    body_a: ground
    body_b: bar
    anchor: [0, 0, 0]
    axis: [0, 1, 0]
";

fn joint_error(from: &str, to: &str) -> String {
    assert!(PENDULUM.contains(from), "test typo: {from}");
    match Scene::from_yaml(&PENDULUM.replacen(from, to, 1), "scene.yaml") {
        Ok(_) => panic!("accepted bad joint: {to}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_joints_are_rejected_with_field_and_line() {
    assert!(Scene::from_yaml(PENDULUM, "scene.yaml").is_ok());
    let e = joint_error("type: revolute", "type: hinge");
    assert!(
        e.starts_with("scene.yaml:9:") && e.contains("joints[0].type") && e.contains("hinge"),
        "{e}"
    );
    let e = joint_error("body_b: bar", "body_b: arm");
    assert!(
        e.starts_with("scene.yaml:11:") && e.contains("unknown body `arm`"),
        "{e}"
    );
    let e = joint_error("    axis: [0, 1, 0]\n", "    axis: [0, 0, 0]\n");
    assert!(
        e.contains("joints[0].axis") && e.contains("zero vector"),
        "{e}"
    );
    let e = joint_error("    axis: [0, 1, 0]\n", "");
    assert!(
        e.contains("joints[0].axis") && e.contains("required"),
        "{e}"
    );
    let e = joint_error(
        "type: revolute",
        "type: spherical\n    drive: { velocity: 1 rad/s }",
    );
    assert!(e.contains("joints[0].drive"), "{e}");
    let e = joint_error(
        "    axis: [0, 1, 0]\n",
        "    axis: [0, 1, 0]\n    limits: { lower: 10 deg, upper: 5 deg }\n",
    );
    assert!(
        e.starts_with("scene.yaml:14:") && e.contains("joints[0].limits"),
        "{e}"
    );
    let e = joint_error(
        "    axis: [0, 1, 0]\n",
        "    axis: [0, 1, 0]\n    drive: { velocity: 1 m/s }\n",
    );
    assert!(
        e.contains("joints[0].drive.velocity") && e.contains("angular velocity"),
        "{e}"
    );
    let e = joint_error("body_a: ground", "body_a: bar");
    assert!(e.contains("two different bodies"), "{e}");
}

#[test]
fn refine_names_an_unknown_contact_or_a_non_positive_step() {
    expect(
        "duration: 1 s\n",
        "duration: 1 s\nrefine: { after: flor, for: 1 ms, h: 1 us }\n",
        "refine.after",
        2,
    );
    assert!(
        error_of(
            "duration: 1 s\n",
            "duration: 1 s\nrefine: { after: flor, for: 1 ms, h: 1 us }\n"
        )
        .contains("floor"),
        "the error lists the contacts there are"
    );
    expect(
        "duration: 1 s\n",
        "duration: 1 s\nrefine: { after: floor, for: 1 ms, h: 0 s }\n",
        "refine.h",
        2,
    );
    expect(
        "duration: 1 s\n",
        "duration: 1 s\nrefine: { after: floor, for: -1 ms, h: 1 us }\n",
        "refine.for",
        2,
    );
    // `until` names an event probe of the scene
    let until = "duration: 1 s\nrefine: { after: floor, for: 1 ms, h: 1 us, until: bounce }\n";
    expect("duration: 1 s\n", until, "refine.until", 2);
    assert!(error_of("duration: 1 s\n", until).contains("unknown event probe `bounce`"));
    let value_probe = format!(
        "{GOOD_BALL}probes:\n  - {{ name: bounce, measure: {{ gap: floor }}, at: 0.5 s }}\n"
    );
    let e = refused(
        &value_probe.replacen("duration: 1 s\n", until, 1),
        "a value probe closing the window",
    );
    assert!(
        e.contains("refine.until") && e.contains("not an event probe"),
        "{e}"
    );
}

/// A legal but implausible value (a unit slip, most often) is warned about with its line
/// and field, and the scene still loads; no bundled scene draws a warning.
#[test]
fn implausible_values_are_warned_about_not_refused() {
    let warnings = |text: &str| Scene::from_yaml(text, "scene.yaml").unwrap().warnings;
    assert!(warnings(GOOD_BALL).is_empty(), "{:?}", warnings(GOOD_BALL));
    // 1000 kg in a 0.1 m ball is 2.4e5 kg/m³, beyond any solid; 1 g is 0.24 kg/m³
    for mass in ["1000 kg", "1 g"] {
        let w = warnings(&GOOD_BALL.replacen("mass: 1 kg", &format!("mass: {mass}"), 1));
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            w[0].starts_with("scene.yaml:4: bodies.ball.mass:") && w[0].contains("density"),
            "{w:?}"
        );
    }
    // an inertia given in g·mm² where kg·m² is meant
    let w = warnings(&GOOD_BALL.replacen(
        "mass: 1 kg",
        "mass: 1 kg\n    inertia: [4000, 4000, 4000]",
        1,
    ));
    assert!(
        w.len() == 1 && w[0].starts_with("scene.yaml:5: bodies.ball.inertia is 1.000e6 times"),
        "{w:?}"
    );
    for name in [
        "bouncing-ball",
        "c60",
        "cam-follower",
        "cam-rocker",
        "four-bar",
        "four-bar-clearance",
        "free-body",
        "heavy-top",
        "incline-block",
        "pendulum",
        "pendulum-clearance",
        "slider-crank-clearance",
    ] {
        let s = Scene::load(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("studies")
                .join(name)
                .join("scene.yaml"),
        )
        .unwrap();
        assert!(s.warnings.is_empty(), "{name}: {:?}", s.warnings);
    }
    // a clearance of 0.1 m (meant as mm) on a 4 mm journal
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("studies/four-bar-clearance/scene.yaml");
    let mut s = Scene::load(&path).unwrap();
    s.set_parameter("joints.C.clearance", 0.1).unwrap();
    assert!(
        s.warnings.len() == 1
            && s.warnings[0]
                .contains("joints.C.clearance: 0.1 m is larger than the journal radius (0.004 m)"),
        "{:?}",
        s.warnings
    );
}

#[test]
fn a_compliant_contact_names_what_is_wrong_with_its_law() {
    let e = "    e: 0.5\n";
    expect(e, "    e: 0.5\n    law: springy\n", "contacts[0].law", 15);
    expect(
        e,
        "    e: 0.5\n    compliance: { stiffness: 1e9 }\n",
        "contacts[0].compliance",
        15,
    );
    expect(
        e,
        "    e: 0.5\n    law: compliant\n",
        "contacts[0].compliance",
        9,
    );
    expect(
        e,
        "    e: 0\n    law: compliant\n    compliance: { stiffness: 1e9 }\n",
        "contacts[0].e",
        16,
    );
    expect(
        e,
        "    e: 0.5\n    law: compliant\n    compliance: { material: { E: 210 GPa, nu: 0.7 } }\n",
        "contacts[0].compliance.material.nu",
        16,
    );
    expect(
        e,
        "    e: 0.5\n    law: compliant\n    compliance: { material: { E: 210 N, nu: 0.3 } }\n",
        "contacts[0].compliance.material.E",
        16,
    );
    expect(
        e,
        "    e: 0.5\n    law: compliant\n    compliance: { stiffness: 1e9, material: { E: 210 GPa, nu: 0.3 } }\n",
        "contacts[0].compliance.stiffness",
        16,
    );
}

#[test]
fn hertz_stiffness_needs_a_sphere() {
    let text = GOOD_BALL
        .replacen(
            "    shape: { sphere: { radius: 0.1 m } }\n    against",
            "    shape: { box: { size: [0.1, 0.1, 0.1] } }\n    against",
            1,
        )
        .replacen(
            "    e: 0.5\n",
            "    e: 0.5\n    law: compliant\n    compliance: { material: { E: 210 GPa, nu: 0.3 } }\n",
            1,
        );
    let e = refused(&text, "a box's Hertz stiffness");
    assert!(
        e.starts_with("scene.yaml:16:") && e.contains("give `stiffness`"),
        "{e}"
    );
}

#[test]
fn a_refinement_window_needs_a_rigid_contact() {
    let text = GOOD_BALL.replacen(
        "    e: 0.5\n",
        "    e: 0.5\n    law: compliant\n    compliance: { stiffness: 1e9 }\nrefine: { after: floor, for: 1 ms, h: 1 us }\n",
        1,
    );
    let e = refused(&text, "a refinement window after a compliant contact");
    assert!(
        e.starts_with("scene.yaml:17:") && e.contains("refine.after") && e.contains("is compliant"),
        "{e}"
    );
}

#[test]
fn step_control_names_its_field() {
    let at = |block: &str| format!("duration: 1 s\nintegrator:\n  step_control: {block}\n");
    let cases = [
        ("{ tolerance: -1e-4 }", "integrator.step_control.tolerance"),
        ("{ tolerance: 1e-4, h_max: 2 kg }", "a time"),
        (
            "{ h_max: 1 us, h_min: 1 ms }",
            "integrator.step_control.h_min",
        ),
        ("{ speed: 0 }", "integrator.step_control.speed"),
        ("sometimes", "must be `off` or a block"),
    ];
    for (block, field) in cases {
        let e = refused(&GOOD_BALL.replacen("duration: 1 s\n", &at(block), 1), block);
        assert!(e.starts_with("scene.yaml:3:"), "wrong line in: {e}");
        assert!(e.contains(field), "`{field}` not named in: {e}");
    }
    // an unknown key inside the block
    let e = refused(
        &GOOD_BALL.replacen("duration: 1 s\n", &at("{ tolerence: 1e-4 }"), 1),
        "typo",
    );
    assert!(e.starts_with("scene.yaml:3:"), "wrong line in: {e}");
    // `off` and a block are both accepted
    for block in ["off", "{ tolerance: 1e-5 }"] {
        let s = Scene::from_yaml(
            &GOOD_BALL.replacen("duration: 1 s\n", &at(block), 1),
            "s.yaml",
        );
        let c = s.unwrap().params.step_control;
        assert_eq!(c.is_some(), block != "off");
    }
}
