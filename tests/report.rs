//! Sensitivity analysis against closed forms, and the report page:
//! - Ishigami (a = 7, b = 0.1, uniform inputs on [−π, π]) with a Saltelli design of base
//!   N = 2^14: Sobol' first-order and total indices within 0.02 of the exact values and
//!   the exact values inside their bootstrap 95 % intervals;
//! - a linear model y = Σ a_i x_i with independent normal inputs: SRC_i² equal to
//!   a_i² σ_i² / Σ_k a_k² σ_k² to 1e-2, R² ≈ 1;
//! - the report of a small mechanism study: every figure file exists and is non-empty, the
//!   HTML page inlines every figure and references nothing outside itself.

mod common;

use common::{scratch, study_path};
use mc_study::report;
use mc_study::study::runner::{run, RunOptions};
use mc_study::study::Study;
use std::path::Path;

fn run_study(dir: &Path, text: &str) -> std::path::PathBuf {
    let f = dir.join("study.yaml");
    std::fs::write(&f, text).unwrap();
    let study = Study::load(&f, None).unwrap_or_else(|e| panic!("{e}"));
    let out = dir.join("out");
    let mut o = RunOptions::new(out.clone());
    o.progress = false;
    run(&study, &o).unwrap();
    out
}

#[test]
fn ishigami_sobol_indices_match_the_closed_form() {
    let dir = scratch("report-ishigami");
    let u = "{ uniform: { lower: -3.141592653589793, upper: 3.141592653589793 } }";
    let out = run_study(
        &dir,
        &format!(
            "scene: {}\nsamples: 16384\nseed: 5\ndesign: saltelli\nparameters:\n  - {{ path: inputs.x1, distribution: {u} }}\n  - {{ path: inputs.x2, distribution: {u} }}\n  - {{ path: inputs.x3, distribution: {u} }}\n",
            study_path("ishigami", "scene.yaml").display()
        ),
    );
    let r = report::build(&out).unwrap();
    let sobol = r.sensitivity[0]
        .sobol
        .as_ref()
        .expect("Saltelli design gives indices");
    assert_eq!(sobol.base_rows, 16384);
    // exact: S = (0.3139, 0.4424, 0), ST = (0.5576, 0.4424, 0.2437)
    let exact_first = [0.3139, 0.4424, 0.0];
    let exact_total = [0.5576, 0.4424, 0.2437];
    for j in 0..3 {
        println!(
            "x{}: S {:.4} [{:.4}, {:.4}] (exact {}), ST {:.4} [{:.4}, {:.4}] (exact {})",
            j + 1,
            sobol.first[j].value,
            sobol.first[j].ci95.0,
            sobol.first[j].ci95.1,
            exact_first[j],
            sobol.total[j].value,
            sobol.total[j].ci95.0,
            sobol.total[j].ci95.1,
            exact_total[j]
        );
    }
    for j in 0..3 {
        for (e, exact, kind) in [
            (sobol.first[j], exact_first[j], "S"),
            (sobol.total[j], exact_total[j], "ST"),
        ] {
            assert!(
                (e.value - exact).abs() < 0.02,
                "{kind}{}: {} vs {exact}",
                j + 1,
                e.value
            );
            assert!(
                e.ci95.0 <= exact && exact <= e.ci95.1,
                "{kind}{}: {exact} outside [{}, {}]",
                j + 1,
                e.ci95.0,
                e.ci95.1
            );
            // an interval that says something: narrower than 0.1
            assert!(e.ci95.1 - e.ci95.0 < 0.1, "{kind}{}: {:?}", j + 1, e.ci95);
        }
    }
}

/// A Saltelli design of 40 inputs (80 Sobol' coordinates): y = Σ a_i x_i with x_i uniform
/// on [0, 1], a = (4, 3, 2, 1) on the first four inputs and 0.2 on the other 36. Its
/// first-order and total indices are a_i² / Σ a_k²: each estimate within 0.03 of it, and
/// the 36 small ones (0.0013 each) far below the large ones.
#[test]
fn a_saltelli_study_of_forty_inputs_finds_the_linear_shares() {
    let dir = scratch("report-forty");
    let weights: Vec<f64> = (0..40)
        .map(|i| [4.0, 3.0, 2.0, 1.0].get(i).copied().unwrap_or(0.2))
        .collect();
    let names: Vec<String> = (1..=40).map(|i| format!("x{i}")).collect();
    let sum = (0..40)
        .map(|i| format!("{}*x{}", weights[i], i + 1))
        .collect::<Vec<_>>()
        .join(" + ");
    let scene = dir.join("scene.yaml");
    std::fs::write(
        &scene,
        format!(
            "type: function\nname: forty\ninputs: [{}]\noutputs:\n  - {{ name: y, expression: \"{sum}\" }}\n",
            names.join(", ")
        ),
    )
    .unwrap();
    let parameters: String = names
        .iter()
        .map(|x| format!("  - {{ path: inputs.{x}, distribution: {{ uniform: {{ lower: 0, upper: 1 }} }} }}\n"))
        .collect();
    let out = run_study(
        &dir,
        &format!(
            "scene: {}\nsamples: 1024\nseed: 9\ndesign: saltelli\nparameters:\n{parameters}",
            scene.display()
        ),
    );
    let r = report::build(&out).unwrap();
    let sobol = r.sensitivity[0].sobol.as_ref().expect("indices");
    let total: f64 = weights.iter().map(|a| a * a).sum();
    for (j, a) in weights.iter().enumerate() {
        let exact = a * a / total;
        for (e, kind) in [(sobol.first[j], "S"), (sobol.total[j], "ST")] {
            assert!(
                (e.value - exact).abs() < 0.03,
                "{kind}{}: {} vs {exact}",
                j + 1,
                e.value
            );
        }
    }
    assert!(sobol.first[3].value > 10.0 * sobol.first[20].value.abs().max(1e-3));
}

/// An output whose mean is far larger than its spread (a time of 1000 ± 1.4 s): its
/// first-order indices are the variance shares, 1/3 and 2/3, with narrow intervals. The
/// uncentred Saltelli estimator's variance grows with mean² / var: it gave intervals
/// hundreds wide here.
#[test]
fn sobol_indices_of_an_output_with_a_large_mean_are_its_variance_shares() {
    let dir = scratch("report-offset");
    let scene = dir.join("scene.yaml");
    std::fs::write(
        &scene,
        "type: function\nname: offset\ninputs: [x1, x2]\noutputs:\n  - { name: y, expression: \"1000 + x1 + sqrt(2)*x2\" }\n",
    )
    .unwrap();
    let out = run_study(
        &dir,
        &format!(
            "scene: {}\nsamples: 1024\nseed: 3\ndesign: saltelli\nparameters:\n  - {{ path: inputs.x1, distribution: {{ normal: {{ mean: 0, sd: 1 }} }} }}\n  - {{ path: inputs.x2, distribution: {{ normal: {{ mean: 0, sd: 1 }} }} }}\n",
            scene.display()
        ),
    );
    let r = report::build(&out).unwrap();
    let sobol = r.sensitivity[0].sobol.as_ref().expect("indices");
    for (j, share) in [1.0 / 3.0, 2.0 / 3.0].iter().enumerate() {
        let e = sobol.first[j];
        println!(
            "S{} = {:.4} [{:.4}, {:.4}] (exact {share:.4})",
            j + 1,
            e.value,
            e.ci95.0,
            e.ci95.1
        );
        assert!(
            (e.value - share).abs() < 0.05,
            "S{}: {} vs {share}",
            j + 1,
            e.value
        );
        assert!(
            e.ci95.0 <= *share && *share <= e.ci95.1,
            "S{}: {:?}",
            j + 1,
            e.ci95
        );
        assert!(e.ci95.1 - e.ci95.0 < 0.2, "S{}: {:?}", j + 1, e.ci95);
    }
}

#[test]
fn linear_model_src_squared_are_the_variance_shares() {
    let dir = scratch("report-linear");
    let scene = dir.join("scene.yaml");
    std::fs::write(
        &scene,
        "type: function\nname: lin\ninputs: [x1, x2, x3]\noutputs:\n  - { name: y, expression: \"1*x1 + 2*x2 + 3*x3\" }\n",
    )
    .unwrap();
    let out = run_study(
        &dir,
        &format!(
            "scene: {}\nsamples: 4096\nseed: 9\ndesign: lhs\nparameters:\n  - {{ path: inputs.x1, distribution: {{ normal: {{ mean: 1, sd: 1 }} }} }}\n  - {{ path: inputs.x2, distribution: {{ normal: {{ mean: 0, sd: 0.5 }} }} }}\n  - {{ path: inputs.x3, distribution: {{ normal: {{ mean: -2, sd: 2 }} }} }}\n",
            scene.display()
        ),
    );
    let r = report::build(&out).unwrap();
    let (src, r2) = r.sensitivity[0].src.clone().unwrap();
    // a² σ² = 1, 1, 36 of 38
    println!(
        "SRC² = {:.4}, {:.4}, {:.4} (exact {:.4}, {:.4}, {:.4}), R² = {r2:.6}",
        src[0] * src[0],
        src[1] * src[1],
        src[2] * src[2],
        1.0 / 38.0,
        1.0 / 38.0,
        36.0 / 38.0
    );
    for (j, share) in [1.0 / 38.0, 1.0 / 38.0, 36.0 / 38.0].iter().enumerate() {
        assert!(
            (src[j] * src[j] - share).abs() < 1e-2,
            "SRC{}² = {} vs {share}",
            j + 1,
            src[j] * src[j]
        );
    }
    assert!(r2 > 0.999, "R² = {r2}");
    let (srrc, rr2) = r.sensitivity[0].srrc.clone().unwrap();
    assert!(
        srrc[2] > srrc[0] && srrc[0] > 0.0 && rr2 > 0.95,
        "{srrc:?} {rr2}"
    );
    assert!(
        r.sensitivity[0].sobol.is_none(),
        "no Sobol' indices without Saltelli"
    );
}

#[test]
fn report_of_a_mechanism_study_is_one_self_contained_page() {
    let dir = scratch("report-ball");
    let out = run_study(
        &dir,
        &std::fs::read_to_string(study_path("bouncing-ball", "study.yaml"))
            .unwrap()
            .replace(
                "scene: scene.yaml",
                &format!(
                    "scene: {}",
                    study_path("bouncing-ball", "scene.yaml").display()
                ),
            )
            .replace("samples: 256", "samples: 32"),
    );
    let r = report::build(&out).unwrap();
    // per output: histogram, ECDF, running statistics, SRC², first-order indices from the
    // samples, the contributors' Pareto chart, one scatter per input; plus two run-health
    // figures
    let (outputs, inputs) = (2, 2);
    assert_eq!(r.figures.len(), outputs * (6 + inputs) + 2);
    for f in &r.figures {
        for ext in ["svg", "png"] {
            let p = f.svg.with_extension(ext);
            let len = std::fs::metadata(&p).map(|m| m.len()).unwrap_or(0);
            assert!(len > 1000, "{} is {len} bytes", p.display());
        }
    }
    let png = std::fs::read(r.figures[0].svg.with_extension("png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let html = std::fs::read_to_string(&r.html).unwrap();
    assert_eq!(
        html.matches("<svg").count(),
        r.figures.len(),
        "every figure inlined"
    );
    for external in ["src=", "href=", "<link", "<script", "url(", "@import"] {
        assert!(!html.contains(external), "the page references `{external}`");
    }
    for needle in [
        "first_impact_time",
        "apex_after_first_bounce",
        "Fidelity",
        "mc-study 0.1.0",
        "wall time",
        "Run health",
        "Study file",
    ] {
        assert!(html.contains(needle), "missing `{needle}`");
    }
}

/// An output constant to round-off and a fixed input have no spread: no Cp, Cpk or
/// correlation (null in summary.json, "–" on the page), never 1e13 or ±1; and a study of
/// one sample prints no NaN anywhere.
#[test]
fn degenerate_statistics_are_undefined_not_numbers() {
    let dir = scratch("report-degenerate");
    std::fs::write(
        dir.join("scene.yaml"),
        "type: function\nname: flat\ninputs: [x, k]\noutputs:\n  - { name: flat, expression: \"0.1*3 + x*1e-14 + k\", unit: m }\n  - { name: y, expression: \"x + k\", unit: m }\n",
    )
    .unwrap();
    let text = |n: u64| {
        format!("scene: scene.yaml\nsamples: {n}\nparameters:\n  - {{ path: inputs.x, distribution: {{ normal: {{ mean: 1, sd: 0.1 }} }} }}\n  - {{ path: inputs.k, distribution: {{ fixed: 0.1 }} }}\nlimits:\n  - {{ output: flat, lower: 0.3 m, upper: 0.5 m }}\n  - {{ output: y, upper: 2 m }}\n")
    };
    let out = run_study(&dir, &text(64));
    let m = mc_study::study::merge::merge(&out, false).unwrap();
    let flat = m.summary.output("flat").unwrap();
    assert_eq!((flat.cp, flat.cpk), (None, None));
    let y = m.summary.output("y").unwrap();
    assert!(y.cpk.is_some_and(|c| c > 2.0));
    for c in &m.summary.correlations {
        let defined = c.input == "inputs.x" && c.output == "y";
        assert_eq!(
            c.pearson.is_finite(),
            defined,
            "{} ~ {}: {}",
            c.input,
            c.output,
            c.pearson
        );
        assert_eq!(c.spearman.is_finite(), defined);
        assert_eq!(
            c.srrc.is_finite(),
            defined,
            "SRRC {} ~ {}",
            c.input,
            c.output
        );
    }
    let printed = m.summary.to_string();
    assert!(
        printed.contains("Cp –, Cpk – (the output is constant: no spread to rate)"),
        "{printed}"
    );
    // shown as the value it is, with six significant digits, not as a measurement
    let row = printed.lines().find(|l| l.starts_with("flat")).unwrap();
    let cells: Vec<&str> = row.split_whitespace().collect();
    assert_eq!(cells[3..], ["0.400000", "constant"], "{printed}");
    assert!(!printed.contains("flat  inputs.x"), "{printed}");
    assert!(flat.constant && !y.constant);
    let html = std::fs::read_to_string(report::build(&out).unwrap().html).unwrap();
    assert!(!html.contains("NaN") && html.contains("<td>0.400000</td><td colspan=\"11\""));
    // one sample: no σ, no Cpk, no NaN on the page
    let one = scratch("report-one-sample");
    std::fs::copy(dir.join("scene.yaml"), one.join("scene.yaml")).unwrap();
    let out = run_study(&one, &text(1));
    let html = std::fs::read_to_string(report::build(&out).unwrap().html).unwrap();
    assert!(!html.contains("NaN"), "NaN on the page of one sample");
}
