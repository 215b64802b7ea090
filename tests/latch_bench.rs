//! The virtual test bench: a spring-loaded latch lifted by a ramp pushed at 4 mm/s, its
//! push force against the latch angle set against the hand formula along the ramp (from
//! the trajectory and from a curve probe), and its quasi-static peak (the peak of the
//! force's mean over 20 ms) at two step sizes; then a study of the bench, its curves
//! stored per sample and compared with measured points.

mod common;

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
  - { name: push, measure: { drive_effort: slide } }
  - { name: push_curve, curve: { x: lift, y: push, grid: "1.5 deg .. 8 deg step 0.25 deg" } }
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
        let run = run_probes(
            sim,
            &scene.probes,
            &scene.curves,
            scene.duration,
            false,
            |s, _, _| curves.record(s),
        );
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
        // the curve probe: each grid angle's cell mean against the formula there
        let curve = &run.curves[0];
        assert_eq!(curve.len(), 27);
        for (i, f) in curve.iter().enumerate() {
            let th = (1.5 + 0.25 * i as f64).to_radians();
            let exact = hand_push(th, alpha);
            assert!(
                (f - exact).abs() < 0.01 * exact,
                "h = {h}, curve at θ = {th}: {f} N against {exact} N"
            );
        }
        let got = run.values[1].clone().unwrap();
        assert!(
            (got - peak).abs() < 0.01 * peak,
            "h = {h}: quasi-static peak {got} N against {peak} N"
        );
    }
}

/// The type-7 median of a slice (NaN left out), as NumPy computes it.
fn median(mut v: Vec<f64>) -> Option<f64> {
    v.retain(|x| !x.is_nan());
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return None;
    }
    let h = (n - 1) as f64 * 0.5;
    let lo = h.floor() as usize;
    Some(v[lo] + (h - lo as f64) * (v[(lo + 1).min(n - 1)] - v[lo]))
}

/// A study of the bench with its preload, stiffness and friction toleranced: every
/// sample's curve is stored (a Parquet list column that reads back bit for bit), and the
/// report draws the band and compares measured points (the hand formula at nominal, in
/// degrees and newtons) with the median, as computed here by hand from the stored curves.
#[test]
fn a_study_stores_its_curves_and_compares_them_with_measured_points() {
    let dir = common::scratch("latch-bench-study");
    let scene = BENCH.replace(
        "grid: \"1.5 deg .. 8 deg step 0.25 deg\" } }",
        "grid: \"1.5 deg .. 8 deg step 0.25 deg\" }, reference: bench.csv }",
    );
    std::fs::write(dir.join("scene.yaml"), scene).unwrap();
    let alpha = 30f64.to_radians();
    let degrees = [2.1, 3.3, 4.7, 6.2, 7.9, 9.5];
    let mut csv = String::from("# the hand formula at nominal\nlift [deg], push [N]\n");
    for d in degrees {
        csv += &format!("{d}, {}\n", hand_push(f64::to_radians(d), alpha));
    }
    std::fs::write(dir.join("bench.csv"), csv).unwrap();
    std::fs::write(
        dir.join("study.yaml"),
        "scene: scene.yaml\nsamples: 24\nseed: 3\ndesign: lhs\noutput: out\nparameters:\n  - { path: forces.0.torsional_spring.preload, distribution: { normal: { mean: 0.05 N*m, sd: 0.002 N*m } } }\n  - { path: forces.0.torsional_spring.stiffness, distribution: { normal: { mean: 0.2 N*m, sd: 0.01 N*m } } }\n  - { path: contacts.nose.mu, distribution: { uniform: { lower: 0.17, upper: 0.23 } } }\n",
    )
    .unwrap();
    // measured points that cannot be read stop the study at load, naming the file's line
    let good = std::fs::read_to_string(dir.join("bench.csv")).unwrap();
    std::fs::write(dir.join("bench.csv"), good.replace("4.7, ", "4.7; x")).unwrap();
    let e = mc_study::study::Study::load(&dir.join("study.yaml"), None)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("probes[3].reference") && e.contains("bench.csv: line 5: `x"),
        "{e}"
    );
    std::fs::write(dir.join("bench.csv"), good).unwrap();
    let study = mc_study::study::Study::load(&dir.join("study.yaml"), None)
        .unwrap_or_else(|e| panic!("{e}"));
    let mut o = mc_study::study::runner::RunOptions::new(dir.join("out"));
    o.progress = false;
    mc_study::study::runner::run(&study, &o).unwrap();
    let merged = mc_study::study::merge::merge(&dir.join("out"), false).unwrap();
    let rows = common::stored_rows(&merged.path);
    assert_eq!(rows.len(), 24);
    for r in &rows {
        let again = study.row(r.id);
        assert_eq!(r.curves.len(), 1);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            bits(&r.curves[0]),
            bits(&again.curves[0]),
            "sample {}",
            r.id
        );
        assert_eq!(r.curves[0].len(), 27);
        assert!(r.curves[0].iter().all(|y| y.is_finite()));
    }
    let report = mc_study::report::build(&dir.join("out")).unwrap();
    let view = &report.curves[0];
    let measured = view.reference.as_ref().unwrap().as_ref().unwrap();
    let c = &measured.comparison;
    assert_eq!((c.compared, c.outside_grid), (5, 1));
    // the median by hand: per grid point over the stored curves, then linear between the
    // two grid points around each measured angle
    let (start, step) = (1.5f64.to_radians(), 0.25f64.to_radians());
    let at = |i: usize| median(rows.iter().map(|r| r.curves[0][i]).collect()).unwrap();
    let errors: Vec<f64> = degrees[..5]
        .iter()
        .map(|&d| {
            let s = (f64::to_radians(d) - start) / step;
            let i = s.floor() as usize;
            let m = at(i) + (s - i as f64) * (at(i + 1) - at(i));
            m - hand_push(f64::to_radians(d), alpha)
        })
        .collect();
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / 5.0).sqrt();
    let worst = errors.iter().fold(0.0f64, |m, e| m.max(e.abs()));
    println!(
        "median against the nominal hand curve: RMS {rms:.3e} N, max {worst:.3e} N; in band {:?}",
        c.in_band
    );
    assert!((c.rms.unwrap() - rms).abs() < 1e-12 * rms.max(1e-9));
    assert!((c.max_abs.unwrap() - worst).abs() < 1e-12 * worst.max(1e-9));
    // the population's median lies near the nominal curve, and the band holds it
    assert!(rms < 0.01 * hand_push(0.1, alpha), "RMS {rms} N");
    assert_eq!(c.in_band, Some(1.0));
    let svg = std::fs::read_to_string(
        &report
            .figures
            .iter()
            .find(|f| f.section == "curves")
            .unwrap()
            .svg,
    )
    .unwrap();
    assert!(svg.contains("<polygon"), "the band is drawn");
    assert!(
        svg.matches("<circle").count() >= 6,
        "the measured points are drawn"
    );
    let html = std::fs::read_to_string(&report.html).unwrap();
    assert!(
        html.contains("against 5 measured points"),
        "the page states the comparison"
    );
}
