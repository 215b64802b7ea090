//! Parameters written as a drawing states them: a nominal value, a tolerance band and a
//! process capability. Checked against σ = (t₊ + t₋)/(6 Cp) and the band's centre within
//! their sampling errors, and refused with the field named when they cannot hold.

use mc_study::study::{Distribution, Study};
use std::path::Path;

fn study(tolerance: &str, design: &str, n: u64) -> Result<Study, String> {
    let text = format!(
        "name: t\nscene: linear.yaml\nsamples: {n}\nseed: 5\ndesign: {design}\nparameters:\n  - {{ path: inputs.x1, tolerance: {tolerance} }}\n  - {{ path: inputs.x2, distribution: {{ uniform: {{ lower: 0, upper: 1 }} }} }}\n"
    );
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    Study::from_yaml(&text, "t.yaml", &base, None).map_err(|e| e.to_string())
}

fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    (
        m,
        (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt(),
    )
}

#[test]
fn plus_minus_with_cp_samples_sigma_t_over_3_cp() {
    let n = 20_000;
    let s = study("{ nominal: 55, plus_minus: 0.05, cp: 1.33 }", "random", n).unwrap();
    let x: Vec<f64> = (0..n).map(|i| s.inputs(i)[0]).collect();
    let (m, sd) = mean_sd(&x);
    let sigma = 0.05 / (3.0 * 1.33);
    // the sample σ within 4 of its standard errors (σ/√(2n)), the mean within 4 of σ/√n
    assert!(
        (sd - sigma).abs() < 4.0 * sigma / (2.0 * n as f64).sqrt(),
        "σ {sd} against {sigma}"
    );
    assert!(
        (m - 55.0).abs() < 4.0 * sigma / (n as f64).sqrt(),
        "mean {m}"
    );
    assert_eq!(
        s.parameters[0].distribution,
        Distribution::Normal {
            mean: 55.0,
            sd: sigma
        }
    );
}

#[test]
fn an_asymmetric_band_is_centred_on_its_middle() {
    // +0.05 / −0.02 at Cp 1: σ = 0.07 / 6, centred on 55.015
    let n = 20_000;
    let s = study("{ nominal: 55, plus: 0.05, minus: 0.02 }", "lhs", n).unwrap();
    let x: Vec<f64> = (0..n).map(|i| s.inputs(i)[0]).collect();
    let (m, sd) = mean_sd(&x);
    assert!((m - 55.015).abs() < 1e-4, "mean {m}");
    assert!((sd / (0.07 / 6.0) - 1.0).abs() < 0.02, "σ {sd}");
}

#[test]
fn a_uniform_tolerance_fills_the_band() {
    let n = 4096;
    let s = study(
        "{ nominal: 10, plus: 0.1, minus: 0.3, distribution: uniform }",
        "sobol",
        n,
    )
    .unwrap();
    let x: Vec<f64> = (0..n).map(|i| s.inputs(i)[0]).collect();
    let lo = x.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    assert!(
        (9.7..9.7 + 1e-3).contains(&lo) && (10.1 - 1e-3..=10.1).contains(&hi),
        "{lo} {hi}"
    );
    let (m, sd) = mean_sd(&x);
    assert!((m - 9.9).abs() < 1e-3 && (sd / (0.4 / 12f64.sqrt()) - 1.0).abs() < 0.01);
}

#[test]
fn impossible_tolerances_are_refused_by_field() {
    let cases = [
        (
            "{ nominal: 55, plus_minus: -0.05 }",
            "tolerance.plus_minus",
            "width ≥ 0",
        ),
        (
            "{ nominal: 55, plus_minus: 0.05, cp: 0 }",
            "tolerance.cp",
            "must be > 0",
        ),
        (
            "{ nominal: 55, plus_minus: 0.05, cp: -1 }",
            "tolerance.cp",
            "must be > 0",
        ),
        (
            "{ nominal: 55, plus: 0.05 }",
            "tolerance",
            "both `plus` and `minus`",
        ),
        ("{ nominal: 55, plus_minus: 0 }", "tolerance", "no width"),
        (
            "{ nominal: 55, plus_minus: 0.05, cp: 1.33, distribution: uniform }",
            "tolerance.cp",
            "no process capability",
        ),
        (
            "{ nominal: 55, plus_minus: 0.05, distribution: beta }",
            "tolerance.distribution",
            "normal or uniform",
        ),
    ];
    for (t, field, why) in cases {
        let e = study(t, "random", 10).err().unwrap_or_default();
        assert!(
            e.contains(field) && e.contains(why) && e.contains("t.yaml:"),
            "{t}: {e}"
        );
    }
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let both = "name: t\nscene: linear.yaml\nsamples: 4\nparameters:\n  - { path: inputs.x1, tolerance: { nominal: 1, plus_minus: 0.1 }, distribution: { normal: { mean: 1, sd: 0.1 } } }\n";
    let e = Study::from_yaml(both, "t.yaml", &base, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("not both"), "{e}");
    let neither = "name: t\nscene: linear.yaml\nsamples: 4\nparameters:\n  - { path: inputs.x1 }\n";
    let e = Study::from_yaml(neither, "t.yaml", &base, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("give a `distribution` or a `tolerance`"), "{e}");
}
