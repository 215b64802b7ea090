//! Studies over dimensions and spring rates against closed forms: a slider-crank's slider
//! position at the top dead centre, r + l, sampled through body-frame pin positions (its
//! mean, σ and SRC); a block's static deflection m g / k on a spring of sampled rate.

mod common;

use common::scratch;
use mc_study::study::merge::merge;
use mc_study::study::runner::{run, RunOptions};
use mc_study::study::Study;
use std::path::Path;

/// Runs `study` (text, next to `scene`) into a fresh directory; the merged summary.
fn run_study(tag: &str, scene: &str, study: &str) -> mc_study::study::merge::Merged {
    let dir = scratch(tag);
    std::fs::write(dir.join("scene.yaml"), scene).unwrap();
    std::fs::write(dir.join("study.yaml"), study).unwrap();
    let study = Study::load(&dir.join("study.yaml"), None).unwrap_or_else(|e| panic!("{e}"));
    let mut o = RunOptions::new(dir.join("out"));
    o.progress = false;
    run(&study, &o).unwrap();
    merge(&dir.join("out"), false).unwrap()
}

/// Crank r = 50 mm (pins at ∓25 mm in its frame) and rod l = 120 mm (pins at ∓60 mm), pins
/// in the bodies' frames; the slider's distance from the crank pivot with the crank along
/// +x is r + l once assembled.
const SLIDER_CRANK: &str = r#"
name: slider-crank-dimensions
duration: 1 us
gravity: [0, 0, 0]
integrator: { h: 1 us }
bodies:
  - { name: crank, mass: 0.1, shape: { box: { size: [0.05, 0.01, 0.01] } }, position: [0.025, 0, 0] }
  - { name: rod, mass: 0.2, shape: { box: { size: [0.12, 0.01, 0.01] } }, position: [0.11, 0, 0] }
  - { name: slider, mass: 0.1, shape: { box: { size: [0.03, 0.02, 0.02] } }, position: [0.17, 0, 0] }
joints:
  - { name: pivot, type: revolute, body_a: ground, body_b: crank, anchor_a: [0, 0, 0], anchor_b: [-25 mm, 0, 0],
      axis_a: [0, 1, 0], axis_b: [0, 1, 0] }
  - { name: pin, type: revolute, body_a: crank, body_b: rod, anchor_a: [25 mm, 0, 0], anchor_b: [-60 mm, 0, 0],
      axis_a: [0, 1, 0], axis_b: [0, 1, 0] }
  - { name: wrist, type: revolute, body_a: rod, body_b: slider, anchor_a: [60 mm, 0, 0], anchor_b: [0, 0, 0],
      axis_a: [0, 1, 0], axis_b: [0, 1, 0] }
  - { name: slide, type: prismatic, body_a: ground, body_b: slider, anchor: [0.17, 0, 0], axis: [1, 0, 0] }
probes:
  - name: top_dead_centre
    measure: { distance: { from: { body: ground }, to: { body: slider }, axis: [1, 0, 0] } }
    at: 0 s
    unit: mm
"#;

#[test]
fn a_study_linear_in_two_dimensions_matches_its_closed_form() {
    // the crank's pin (so r) and the rod's far pin (so l) vary: x = r + l
    let (sr, sl): (f64, f64) = (0.1e-3, 0.2e-3);
    let study = format!(
        r#"
scene: scene.yaml
samples: 2000
seed: 7
design: lhs
parameters:
  - {{ path: joints.pin.anchor_a.x, distribution: {{ normal: {{ mean: 25 mm, sd: {sr} }} }} }}
  - {{ path: joints.wrist.anchor_a.x, distribution: {{ normal: {{ mean: 60 mm, sd: {sl} }} }} }}
"#
    );
    let m = run_study("linear-dimensions", SLIDER_CRANK, &study);
    assert_eq!(m.summary.failed, 0, "{:?}", m.summary.failures);
    let o = &m.summary.outputs[0];
    // the declared display unit
    assert_eq!(o.display_unit, "mm");
    assert_eq!(o.display_factor, 1e3);
    // x = r + l with r = 25 mm + the crank's pin, l = 60 mm + the rod's far pin: mean
    // 0.17 m, σ² = σr² + σl²
    let n = o.count as f64;
    let sd = (sr * sr + sl * sl).sqrt();
    assert!(
        (o.mean - 0.17).abs() < 4.0 * sd / n.sqrt(),
        "mean {}",
        o.mean
    );
    assert!(
        (o.sd - sd).abs() < 4.0 * sd / (2.0 * (n - 1.0)).sqrt(),
        "σ {} vs {sd}",
        o.sd
    );
    // every sample exactly: r + l from the sampled pins
    let t = mc_study::study::store::read(&m.path).unwrap();
    for r in &t.rows {
        let exact = (0.025 + r.inputs[0]) + (0.06 + r.inputs[1]);
        assert!(
            (r.outputs[0] - exact).abs() < 1e-12,
            "{} vs {exact}",
            r.outputs[0]
        );
    }
    // SRC: σr/σ and σl/σ, with a perfect linear fit
    let xs: Vec<Vec<f64>> = (0..2)
        .map(|j| t.rows.iter().map(|r| r.inputs[j]).collect())
        .collect();
    let y: Vec<f64> = t.rows.iter().map(|r| r.outputs[0]).collect();
    let src = mc_study::study::sensitivity::src(&xs, &y).unwrap();
    assert!((src.r2 - 1.0).abs() < 1e-9, "R² {}", src.r2);
    for (got, want) in src.coefficients.iter().zip([sr / sd, sl / sd]) {
        assert!((got - want).abs() < 0.02, "SRC {got} vs {want}");
    }
}

/// A 1 kg block on a vertical slide hung from a spring; settled (damped near critically),
/// it rests m g / k below the spring's free position.
const SPRING: &str = r#"
name: spring-deflection
duration: 2 s
gravity: [0, 0, -9.81]
integrator: { h: 1 ms }
settle: { until: 2 s, damping: 60 Hz }
bodies:
  - { name: block, mass: 1 kg, shape: { box: { size: [0.05, 0.05, 0.05] } }, position: [0, 0, -0.2] }
joints:
  - { name: slide, type: prismatic, body_a: ground, body_b: block, anchor: [0, 0, -0.2], axis: [0, 0, 1] }
forces:
  - name: suspension
    spring: { body_a: ground, point_a: [0, 0, 0], body_b: block, stiffness: 1000 N/m }
probes:
  - { name: deflection, measure: { displacement: slide }, unit: mm }
"#;

#[test]
fn a_spring_rate_tolerance_gives_the_static_deflection() {
    let (k1, k2): (f64, f64) = (900.0, 1100.0);
    let study = format!(
        r#"
scene: scene.yaml
samples: 64
seed: 3
design: sobol
parameters:
  - {{ path: forces.suspension.spring.stiffness, distribution: {{ uniform: {{ lower: {k1} N/m, upper: {k2} N/m }} }} }}
"#
    );
    let m = run_study("spring-rate", SPRING, &study);
    assert_eq!(m.summary.failed, 0, "{:?}", m.summary.failures);
    let g = 9.81;
    let t = mc_study::study::store::read(&m.path).unwrap();
    for r in &t.rows {
        let exact = -g / r.inputs[0];
        assert!(
            (r.outputs[0] - exact).abs() < 1e-9 * exact.abs(),
            "k = {}: {} vs {exact}",
            r.inputs[0],
            r.outputs[0]
        );
    }
    // the mean deflection: E[−g/k] for k uniform = −g ln(k2/k1)/(k2 − k1)
    let exact_mean = -g * (k2 / k1).ln() / (k2 - k1);
    let o = &m.summary.outputs[0];
    assert!(
        (o.mean - exact_mean).abs() < 1e-4 * exact_mean.abs(),
        "{} vs {exact_mean}",
        o.mean
    );
    assert!(Path::new(&m.path).exists());
}
