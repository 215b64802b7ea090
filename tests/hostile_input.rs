//! Hostile and malformed input: nothing crashes the process, and every refusal names the
//! file and the field. Includes a bounded property test (proptest) of the study, scene and
//! expression parsers over random text and over mutations of the bundled files.

mod common;

use common::scratch;
use mc_study::input::expr::Expr;
use mc_study::scene::Scene;
use mc_study::study::sample_run::Subject;
use mc_study::study::Study;
use proptest::prelude::*;
use std::path::Path;

fn studies() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/studies"))
}

fn function_scene(expression: &str) -> String {
    format!("type: function\nname: f\ninputs: [x]\noutputs:\n  - {{ name: y, expression: \"{expression}\" }}\n")
}

/// Expressions that used to overflow the stack (SIGABRT, no message) are refused with the
/// field named, or evaluated without recursion.
#[test]
fn deep_or_long_expressions_are_refused_by_field_or_evaluated() {
    for (what, text) in [
        (
            "parentheses",
            format!("{}x{}", "(".repeat(10_000), ")".repeat(10_000)),
        ),
        ("a ^ chain", vec!["x"; 20_000].join("^")),
    ] {
        let e = Subject::from_yaml(&function_scene(&text), "deep.yaml").unwrap_err();
        let e = e.to_string();
        assert!(
            e.starts_with("deep.yaml:5:")
                && e.contains("outputs[0].expression")
                && e.contains("nested more than"),
            "{what}: {e}"
        );
    }
    // 100,000 unary minuses and a 200,000-term sum are fine, in a study's worker too
    let dir = scratch("hostile-long-sum");
    let sum = vec!["x"; 200_000].join(" + ");
    std::fs::write(dir.join("scene.yaml"), function_scene(&sum)).unwrap();
    std::fs::write(
        dir.join("study.yaml"),
        "name: long\nscene: scene.yaml\nsamples: 4\nparameters:\n  - { path: inputs.x, distribution: { uniform: { lower: 1, upper: 2 } } }\n",
    )
    .unwrap();
    let study = Study::load(&dir.join("study.yaml"), None).unwrap();
    for i in 0..4 {
        let row = study.row(i);
        assert_eq!(row.error, None);
        // 200,000 roundings of ε/2 each at most
        let exact = 200_000.0 * row.inputs[0];
        assert!((row.outputs[0] - exact).abs() <= 200_000.0 * f64::EPSILON * exact);
    }
    let signs = format!("{}x", "-".repeat(100_000));
    let s = Subject::from_yaml(&function_scene(&signs), "signs.yaml").unwrap();
    assert_eq!(s.run(&[("inputs.x", 0.5)], &[0]).outputs, vec![0.5]);
}

/// A study or scene path that names something huge (`/dev/zero`) is refused, not read.
#[test]
fn endless_files_are_refused_without_being_read() {
    let e = Study::load(Path::new("/dev/zero"), None).unwrap_err();
    assert!(e.to_string().contains("larger than 16 MiB"), "{e}");
    let e = Scene::load(Path::new("/dev/zero")).unwrap_err();
    assert!(e.to_string().contains("larger than 16 MiB"), "{e}");
}

/// A distribution whose support reaches values the scene refuses is refused at load, naming
/// the parameter: e ~ U[0.5, 1.5] can give e > 1. A support that only touches a forbidden
/// value at an end of probability zero (a clearance truncated at 0) is accepted.
#[test]
fn distributions_reaching_invalid_values_are_refused_at_load() {
    let dir = scratch("hostile-support");
    let scene = studies().join("bouncing-ball/scene.yaml");
    let study = |dist: &str| {
        format!(
            "name: s\nscene: {}\nsamples: 4\nparameters:\n  - path: contacts.floor.e\n    distribution: {dist}\n",
            scene.display()
        )
    };
    std::fs::write(
        dir.join("bad.yaml"),
        study("{ uniform: { lower: 0.5, upper: 1.5 } }"),
    )
    .unwrap();
    let e = Study::load(&dir.join("bad.yaml"), None)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("bad.yaml:6:")
            && e.contains("parameters[0].distribution")
            && e.contains("contacts[0].e"),
        "{e}"
    );
    std::fs::write(
        dir.join("edge.yaml"),
        study("{ truncated_normal: { mean: 0.5, sd: 0.3, lower: 0, upper: 1 } }"),
    )
    .unwrap();
    Study::load(&dir.join("edge.yaml"), None).unwrap();
    // a normal has no bounded support: its rare invalid samples fail as rows
    std::fs::write(
        dir.join("normal.yaml"),
        study("{ normal: { mean: 0.9, sd: 0.05 } }"),
    )
    .unwrap();
    Study::load(&dir.join("normal.yaml"), None).unwrap();
}

/// Flips, truncations and splices of a bundled file's text.
fn mutate(text: &str, ops: &[(u8, usize, u8)]) -> String {
    let mut b = text.as_bytes().to_vec();
    for &(op, at, byte) in ops {
        if b.is_empty() {
            break;
        }
        let at = at % b.len();
        match op % 4 {
            0 => b[at] = byte,
            1 => b.truncate(at),
            2 => b.insert(at, byte),
            _ => {
                let end = (at + usize::from(byte)).min(b.len());
                let piece = b[at..end].to_vec();
                b.splice(at..at, piece);
            }
        }
    }
    String::from_utf8_lossy(&b).into_owned()
}

fn bundled_texts() -> Vec<(String, String)> {
    let mut v = Vec::new();
    for name in ["bouncing-ball", "c60", "four-bar-clearance", "ishigami"] {
        let d = studies().join(name);
        v.push((
            std::fs::read_to_string(d.join("scene.yaml")).unwrap(),
            std::fs::read_to_string(d.join("study.yaml")).unwrap(),
        ));
    }
    v
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]

    /// Any text: the expression parser returns a value or an error, never panics.
    #[test]
    fn the_expression_parser_never_panics(text in "[-+*/^(),. 0-9a-z]{0,200}") {
        let names = vec!["x".to_string(), "y".to_string()];
        if let Ok(e) = Expr::parse(&text, &names) {
            let _ = e.eval(&[0.5, -2.0]);
        }
    }

    /// Mutated bundled scenes and studies: loading gives a scene, a study or an error that
    /// names the file, never a panic.
    #[test]
    fn mutated_scenes_and_studies_load_or_are_refused_by_name(
        which in 0usize..4,
        ops in proptest::collection::vec((any::<u8>(), any::<usize>(), any::<u8>()), 1..6),
    ) {
        let texts = bundled_texts();
        let (scene, study) = &texts[which];
        let scene = mutate(scene, &ops);
        if let Err(e) = Subject::from_yaml(&scene, "scene.yaml") {
            prop_assert!(e.to_string().starts_with("scene.yaml"), "{}", e);
        }
        let study = mutate(study, &ops);
        let base = studies().join(["bouncing-ball", "c60", "four-bar-clearance", "ishigami"][which]);
        if let Err(e) = Study::from_yaml(&study, "study.yaml", &base, Some(2)) {
            let e = e.to_string();
            prop_assert!(e.contains("study.yaml") || e.contains("scene.yaml"), "{}", e);
        }
    }
}
