//! Bad study files: each error names the field and the line.

mod common;

use common::{scratch, study_path};
use mc_study::study::Study;

/// The bouncing-ball study with `from` replaced by `to`; returns the error text.
fn error_of(tag: &str, from: &str, to: &str) -> String {
    let text = std::fs::read_to_string(study_path("bouncing-ball", "study.yaml")).unwrap();
    assert!(text.contains(from), "the bundled study has no `{from}`");
    let scene = study_path("bouncing-ball", "scene.yaml");
    let text = text
        .replace(from, to)
        .replace("scene: scene.yaml", &format!("scene: {}", scene.display()));
    let dir = scratch(&format!("study-error-{tag}"));
    let f = dir.join("study.yaml");
    std::fs::write(&f, &text).unwrap();
    let e = Study::load(&f, None)
        .err()
        .unwrap_or_else(|| panic!("{tag}: accepted"));
    e.to_string()
}

fn line_of(needle: &str) -> u64 {
    let text = std::fs::read_to_string(study_path("bouncing-ball", "study.yaml")).unwrap();
    text.lines().position(|l| l.contains(needle)).unwrap() as u64 + 1
}

fn assert_names(e: &str, field: &str, line: u64, what: &str) {
    assert!(
        e.contains(&format!("study.yaml:{line}:")),
        "no line {line} in: {e}"
    );
    assert!(
        e.contains(&format!("`{field}`")),
        "no field `{field}` in: {e}"
    );
    assert!(e.contains(what), "no `{what}` in: {e}");
}

#[test]
fn unknown_parameter_path() {
    let e = error_of("path", "path: contacts.floor.e", "path: contacts.flor.e");
    assert_names(
        &e,
        "parameters[0].path",
        line_of("contacts.floor.e"),
        "unknown parameter path `contacts.flor.e`; the nearest are: contacts.floor.e",
    );
    let e = error_of(
        "field",
        "path: contacts.floor.e",
        "path: contacts.floor.colour",
    );
    assert_names(
        &e,
        "parameters[0].path",
        line_of("contacts.floor.e"),
        "unknown parameter path `contacts.floor.colour`",
    );
    // the nearest paths of a wrong component, and a path that stops at a vector
    let e = error_of(
        "axis",
        "path: bodies.ball.position.z",
        "path: bodies.ball.position.q",
    );
    assert_names(
        &e,
        "parameters[1].path",
        line_of("bodies.ball.position.z"),
        "`position` has the components x, y, z",
    );
    let e = error_of(
        "vector",
        "path: bodies.ball.position.z",
        "path: bodies.ball.position",
    );
    assert!(e.contains("name a component of `position`: x, y, z"), "{e}");
}

#[test]
fn negative_sigma() {
    let e = error_of("sigma", "sd: 0.05 m", "sd: -0.05 m");
    assert_names(
        &e,
        "parameters[1].distribution.normal",
        line_of("sd: 0.05 m"),
        "sd must be ≥ 0",
    );
}

#[test]
fn truncated_distribution_without_mass() {
    let e = error_of(
        "mass",
        "normal: { mean: 1 m, sd: 0.05 m }",
        "truncated_normal: { mean: 1 m, sd: 0.05 m, lower: 4 m, upper: 5 m }",
    );
    assert_names(
        &e,
        "parameters[1].distribution.truncated_normal",
        line_of("sd: 0.05 m"),
        "no mass",
    );
}

#[test]
fn zero_samples() {
    let e = error_of("n0", "samples: 256", "samples: 0");
    assert_names(
        &e,
        "samples",
        line_of("samples: 256"),
        "must be a whole number ≥ 1, got 0",
    );
}

#[test]
fn unknown_output() {
    let e = error_of(
        "output",
        "outputs: [first_impact_time, apex_after_first_bounce]",
        "outputs: [first_impact_time, apex]",
    );
    assert_names(&e, "outputs[1]", line_of("outputs: ["), "unknown output `apex` (the scene's outputs: first_impact_time, second_impact_time, apex_after_first_bounce)");
}

#[test]
fn wrong_units_unknown_design_and_unknown_keys() {
    let e = error_of("unit", "sd: 0.05 m", "sd: 0.05 s");
    assert_names(
        &e,
        "parameters[1].distribution.normal.sd",
        line_of("sd: 0.05 m"),
        "a length",
    );
    let e = error_of("design", "design: lhs", "design: halton");
    assert_names(
        &e,
        "design",
        line_of("design: lhs"),
        "unknown design `halton` (random, lhs, sobol, saltelli)",
    );
    let e = error_of("key", "seed: 2026", "sed: 2026");
    assert!(
        e.contains(&format!(":{}", line_of("seed: 2026"))) && e.contains("sed"),
        "{e}"
    );
    let e = error_of("limit", "lower: 0.6 m", "lower: 0.6 N");
    assert_names(&e, "limits[0].lower", line_of("lower: 0.6 m"), "a length");
    let e = error_of("scene", "scene: scene.yaml", "scene: nowhere.yaml");
    assert!(e.contains("`scene`") && e.contains("cannot read"), "{e}");
}

/// Fidelity presets scale the scene's own settings; the explicit keys of the block win; an
/// unknown preset names the field and the line.
#[test]
fn fidelity_presets_and_an_unknown_preset() {
    use mc_study::study::sample_run::Subject;
    let load = |tag: &str, to: &str| {
        let text = std::fs::read_to_string(study_path("bouncing-ball", "study.yaml")).unwrap();
        let scene = study_path("bouncing-ball", "scene.yaml");
        let text = text
            .replace("fidelity:\n  h: 0.1 ms", to)
            .replace("scene: scene.yaml", &format!("scene: {}", scene.display()));
        let f = scratch(&format!("study-preset-{tag}")).join("study.yaml");
        std::fs::write(&f, &text).unwrap();
        let study = Study::load(&f, None).unwrap();
        let Subject::Mechanism(scene) = &study.subject else {
            panic!("a mechanism")
        };
        (scene.params.h, scene.params.solver.tolerance)
    };
    // the scene itself: h = 1 ms, solver tolerance 1e-10 (the engine default)
    let (h, tol) = load("none", "");
    assert_eq!((h, tol), (1e-3, 1e-10));
    assert_eq!(load("fast", "fidelity: { preset: fast }"), (4e-3, 1e-8));
    assert_eq!(load("balanced", "fidelity: { preset: balanced }"), (h, tol));
    assert_eq!(
        load("accurate", "fidelity: { preset: accurate }"),
        (2.5e-4, 1e-12)
    );
    assert_eq!(
        load("override", "fidelity: { preset: accurate, h: 0.1 ms }"),
        (1e-4, 1e-12)
    );
    let e = error_of(
        "preset",
        "fidelity:\n  h: 0.1 ms",
        "fidelity:\n  preset: quick",
    );
    assert_names(
        &e,
        "fidelity.preset",
        line_of("fidelity:") + 1,
        "unknown preset `quick` (available: fast, balanced, accurate)",
    );
}

/// A study's name makes its default output directory results/<name>: a name that is a
/// path would write elsewhere, so it is refused.
#[test]
fn a_study_name_must_be_a_plain_name() {
    for name in ["../../../../x", "a/b", ".."] {
        let e = error_of(
            "path-name",
            "name: bouncing-ball",
            &format!("name: \"{name}\""),
        );
        assert_names(
            &e,
            "name",
            line_of("name: bouncing-ball"),
            "must be a plain name",
        );
    }
}
