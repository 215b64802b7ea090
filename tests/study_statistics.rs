//! Study statistics against closed forms: moments and quantiles of analytic outputs within
//! their Monte-Carlo error, every distribution's sample mean against its exact mean, the
//! lower error of LHS and Sobol' designs at equal N, and the bouncing-ball study against
//! its closed-form answers.

mod common;

use common::{scratch, study_path};
use mc_study::study::merge::merge;
use mc_study::study::runner::{run, RunOptions};
use mc_study::study::{Distribution, Study};
use statrs::distribution::{Continuous, ContinuousCDF, Normal};
use std::path::Path;

fn data(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
        .display()
        .to_string()
}

fn study(dir: &Path, text: &str) -> Study {
    let f = dir.join("study.yaml");
    std::fs::write(&f, text).unwrap();
    Study::load(&f, None).unwrap_or_else(|e| panic!("{e}"))
}

fn run_all(study: &Study, out: &Path) -> mc_study::study::merge::Merged {
    let mut o = RunOptions::new(out.to_path_buf());
    o.progress = false;
    run(study, &o).unwrap();
    merge(out, false).unwrap()
}

/// y = 3 x1 + 1 with x1 ~ N(2, 0.5) is N(7, 1.5): mean, σ and quantiles within 4 standard
/// errors; s = x1 + x2 + x3 with a uniform and a triangular input: mean and σ.
#[test]
fn moments_and_quantiles_match_closed_forms_within_monte_carlo_error() {
    let dir = scratch("stats-closed-form");
    let n = 4000;
    let s = study(
        &dir,
        &format!(
            "scene: {}\nsamples: {n}\nseed: 11\nparameters:\n  - {{ path: inputs.x1, distribution: {{ normal: {{ mean: 2, sd: 0.5 }} }} }}\n  - {{ path: inputs.x2, distribution: {{ uniform: {{ lower: -1, upper: 2 }} }} }}\n  - {{ path: inputs.x3, distribution: {{ triangular: {{ lower: 0, mode: 1, upper: 4 }} }} }}\noutputs: [y, s]\nlimits:\n  - {{ output: y, upper: 9.25 }}\n",
            data("linear.yaml")
        ),
    );
    let m = run_all(&s, &dir.join("out"));
    let nf = n as f64;
    let y = &m.summary.outputs[0];
    assert_eq!(y.count, n);
    let (mu, sigma) = (7.0, 1.5);
    println!(
        "y: mean {:.4} (exact {mu}, SE {:.4}), sd {:.4} (exact {sigma}), quantiles {:?}",
        y.mean,
        sigma / nf.sqrt(),
        y.sd,
        y.quantiles
    );
    assert!(
        (y.mean - mu).abs() < 4.0 * sigma / nf.sqrt(),
        "mean {}",
        y.mean
    );
    assert!(y.mean_ci95.0 < y.mean && y.mean < y.mean_ci95.1);
    assert!(
        (y.sd - sigma).abs() < 4.0 * sigma / (2.0 * nf).sqrt(),
        "sd {}",
        y.sd
    );
    let normal = Normal::new(mu, sigma).unwrap();
    for &(p, q) in &y.quantiles {
        let exact = normal.inverse_cdf(p);
        // standard error of the p-quantile: sqrt(p(1 − p)/n) / f(q_p)
        let se = (p * (1.0 - p) / nf).sqrt() / normal.pdf(exact);
        assert!(
            (q - exact).abs() < 4.0 * se,
            "p {p}: {q} vs {exact} (se {se})"
        );
    }
    // P(y > 9.25) = P(z > 1.5) = 0.0668; the Wilson interval covers it
    let os = y.out_of_spec.as_ref().unwrap();
    let exact = 1.0 - Normal::standard().cdf(1.5);
    assert!(
        os.wilson95.0 < exact && exact < os.wilson95.1,
        "{:?} vs {exact}",
        os.wilson95
    );
    assert!((y.cpk.unwrap() - 2.25 / 4.5).abs() < 0.05);
    // s: mean 2 + 0.5 + 5/3, variance 0.25 + 9/12 + (0 + 1 + 16 − 0 − 0 − 4)/18
    let sm = &m.summary.outputs[1];
    let (mean_s, var_s) = (2.0 + 0.5 + 5.0 / 3.0, 0.25 + 0.75 + 13.0 / 18.0);
    assert!(
        (sm.mean - mean_s).abs() < 4.0 * (var_s / nf).sqrt(),
        "mean {}",
        sm.mean
    );
    assert!(
        (sm.sd - var_s.sqrt()).abs() < 0.05 * var_s.sqrt(),
        "sd {}",
        sm.sd
    );
    // correlation of y with x1 is 1, with x2 ~ 0
    let c = |i: &str, o: &str| {
        m.summary
            .correlations
            .iter()
            .find(|c| c.input == i && c.output == o)
            .unwrap()
            .pearson
    };
    assert!((c("inputs.x1", "y") - 1.0).abs() < 1e-12);
    assert!(c("inputs.x2", "y").abs() < 0.06);
}

/// Every distribution, sampled through a study: sample mean within 4 SE of its exact mean.
#[test]
fn every_distribution_samples_its_exact_mean() {
    let dir = scratch("stats-distributions");
    let cases = [
        (
            "normal: { mean: 1.5, sd: 0.25 }",
            Distribution::Normal {
                mean: 1.5,
                sd: 0.25,
            },
        ),
        (
            "truncated_normal: { mean: 0.07, sd: 0.0175, lower: 0.05 }",
            Distribution::TruncatedNormal {
                mean: 0.07,
                sd: 0.0175,
                lower: 0.05,
                upper: f64::INFINITY,
            },
        ),
        (
            "uniform: { lower: -2, upper: 5 }",
            Distribution::Uniform {
                lower: -2.0,
                upper: 5.0,
            },
        ),
        (
            "lognormal: { mean: 3, sd: 1.2 }",
            Distribution::lognormal(3.0, 1.2).unwrap(),
        ),
        (
            "triangular: { lower: 1, mode: 4, upper: 5 }",
            Distribution::Triangular {
                lower: 1.0,
                mode: 4.0,
                upper: 5.0,
            },
        ),
        ("fixed: 0.7", Distribution::Fixed(0.7)),
    ];
    for (k, (spec, dist)) in cases.iter().enumerate() {
        let d = dir.join(k.to_string());
        std::fs::create_dir_all(&d).unwrap();
        let s = study(
            &d,
            &format!(
                "scene: {}\nsamples: 3000\nseed: {k}\ndesign: random\nparameters:\n  - {{ path: inputs.x1, distribution: {{ {spec} }} }}\noutputs: [y]\n",
                data("linear.yaml")
            ),
        );
        let xs: Vec<f64> = (0..3000).map(|i| s.inputs(i)[0]).collect();
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        let (m, sd) = dist.moments();
        assert!(
            (mean - m).abs() <= 4.0 * sd / 3000f64.sqrt() + 1e-12 * m.abs(),
            "{spec}: sample mean {mean}, exact {m}"
        );
        if let Distribution::TruncatedNormal { lower, .. } = dist {
            assert!(xs.iter().all(|x| x >= lower));
        }
    }
}

/// At equal N, Latin hypercube and scrambled Sobol' estimate the mean of a smooth function
/// with a much smaller error than plain Monte Carlo (RMS over 16 seeds).
#[test]
fn lhs_and_sobol_beat_random_sampling_at_equal_n() {
    let dir = scratch("stats-designs");
    let exact = 2.0 * (0.5f64.exp() - 1.0) + 1.0 / 3.0 + 0.25;
    let mut rms = Vec::new();
    for design in ["random", "lhs", "sobol"] {
        let mut sq = 0.0;
        for seed in 0..16 {
            let s = study(
                &dir,
                &format!(
                    "scene: {}\nsamples: 256\nseed: {seed}\ndesign: {design}\nparameters:\n  - {{ path: inputs.u, distribution: {{ uniform: {{ lower: 0, upper: 1 }} }} }}\n  - {{ path: inputs.v, distribution: {{ uniform: {{ lower: 0, upper: 1 }} }} }}\n",
                    data("smooth.yaml")
                ),
            );
            let mean = (0..256).map(|i| s.run_sample(i).1.outputs[0]).sum::<f64>() / 256.0;
            sq += (mean - exact).powi(2);
        }
        rms.push((sq / 16.0).sqrt());
    }
    let (random, lhs, sobol) = (rms[0], rms[1], rms[2]);
    println!(
        "RMS error of the mean at N = 256: random {random:.2e}, lhs {lhs:.2e}, sobol {sobol:.2e}"
    );
    // random: σ/√N ≈ 0.42/16 = 2.6e-2
    assert!(random > 0.01 && random < 0.05, "random {random}");
    // LHS removes the additive part of the variance; the u·v term remains
    assert!(lhs < random / 3.0, "lhs {lhs} vs random {random}");
    assert!(sobol < random / 20.0, "sobol {sobol} vs random {random}");
}

/// The bundled quick demo against its closed forms: first impact sqrt(2 g0 / g), apex after
/// the first bounce e² g0 (drop gap g0 = z0 − r), per sample, to the step size.
#[test]
fn bouncing_ball_study_matches_its_closed_forms_per_sample() {
    let s = Study::load(&study_path("bouncing-ball", "study.yaml"), Some(24)).unwrap();
    let out = scratch("stats-bouncing-ball");
    let m = run_all(&s, &out);
    let t = mc_study::study::store::read(&m.path).unwrap();
    for r in &t.rows {
        let (e, z0) = (r.inputs[0], r.inputs[1]);
        let g0 = z0 - 0.1;
        let t1 = (2.0 * g0 / 9.81).sqrt();
        // event-capturing: the impact is seen at the end of the step that closes the contact
        assert!(
            (r.outputs[0] - t1).abs() <= 1.5e-4,
            "sample {}: {} vs {t1}",
            r.id,
            r.outputs[0]
        );
        // apex: first order in h (the impact lasts a step): 1e-3 relative at h = 0.1 ms
        let apex = e * e * g0;
        assert!(
            (r.outputs[1] - apex).abs() < 1e-3 * apex,
            "sample {}: {} vs {apex}",
            r.id,
            r.outputs[1]
        );
    }
}

/// y = x1 − 0.3 x2 with x1 and x2 standard normal at rank correlation 0.9: x2 lowers y,
/// yet its Spearman ρ with y is strongly positive (0.82 in closed form, since x2 follows
/// x1). The summary's strongest inputs rank by the standardised rank regression
/// coefficient, which holds x1 fixed: x1 first at about +1.35 (1/σ_y), then x2 negative at
/// about −0.41 (−0.3/σ_y, σ_y = 0.739).
#[test]
fn strongest_inputs_keep_their_sign_when_inputs_are_correlated() {
    let dir = scratch("stats-correlated-inputs");
    std::fs::write(
        dir.join("scene.yaml"),
        "type: function\nname: partial\ninputs: [x1, x2]\noutputs:\n  - { name: y, expression: \"x1 - 0.3*x2\" }\n",
    )
    .unwrap();
    let s = study(
        &dir,
        "scene: scene.yaml\nsamples: 2000\nseed: 11\nparameters:\n  - { path: inputs.x1, distribution: { normal: { mean: 0, sd: 1 } } }\n  - { path: inputs.x2, distribution: { normal: { mean: 0, sd: 1 } } }\ncorrelations:\n  - { between: [inputs.x1, inputs.x2], rank: 0.9 }\n",
    );
    let m = run_all(&s, &dir.join("out"));
    let of = |input: &str| {
        m.summary
            .correlations
            .iter()
            .find(|c| c.input == input && c.output == "y")
            .unwrap()
            .clone()
    };
    let (x1, x2) = (of("inputs.x1"), of("inputs.x2"));
    assert!(x2.spearman > 0.7, "ρ(x2, y) = {}", x2.spearman);
    assert!((x1.srrc - 1.35).abs() < 0.1, "SRRC(x1) = {}", x1.srrc);
    assert!((x2.srrc + 0.41).abs() < 0.1, "SRRC(x2) = {}", x2.srrc);
    let strongest = m.summary.strongest_inputs("y");
    let names: Vec<&str> = strongest.iter().map(|(c, _)| c.input.as_str()).collect();
    assert_eq!(names, ["inputs.x1", "inputs.x2"]);
    assert!(strongest[1].1 < 0.0);
    let text = m.summary.to_string();
    assert!(text.contains("inputs.x2 -0.4"), "{text}");
}

/// A ball dropped from z ~ U(0.8 m, 1.6 m) for 0.45 s strikes the floor only from below
/// z = 0.1 m + g t²/2 = 1.0933 m. Its optional impact time is empty in the other samples,
/// which stay `ok` with their other outputs, say why in the `missing` column, and are
/// counted apart in the summary; the impact times that exist match √(2 (z − r) / g).
#[test]
fn an_optional_output_is_empty_where_its_event_does_not_happen() {
    let dir = scratch("stats-optional-output");
    std::fs::write(
        dir.join("scene.yaml"),
        r#"
name: drop
duration: 0.45 s
integrator: { h: 0.1 ms, scheme: moreau-jean }
bodies:
  - { name: ball, mass: 1 kg, shape: { sphere: { radius: 0.1 m } }, position: [0, 0, 1 m] }
contacts:
  - name: floor
    body: ball
    shape: { sphere: { radius: 0.1 m } }
    against_shape: { plane: { normal: [0, 0, 1] } }
probes:
  - { name: impact_time, event: { closes: floor }, optional: true }
  - name: final_height
    measure: { distance: { from: { body: ground }, to: { body: ball }, axis: [0, 0, 1] } }
"#,
    )
    .unwrap();
    let s = study(
        &dir,
        "scene: scene.yaml\nsamples: 40\nseed: 3\nparameters:\n  - { path: bodies.ball.position.z, distribution: { uniform: { lower: 0.8 m, upper: 1.6 m } } }\n",
    );
    let m = run_all(&s, &dir.join("out"));
    let t = mc_study::study::store::read(&dir.join("out/results.parquet")).unwrap();
    let reach = 0.1 + 0.5 * 9.81 * 0.45f64.powi(2);
    let mut hits = 0;
    for r in &t.rows {
        assert_eq!(r.status(), "ok");
        assert!(r.outputs[1].is_finite());
        let z = r.inputs[0];
        if z < reach - 1e-3 {
            hits += 1;
            let exact = (2.0 * (z - 0.1) / 9.81).sqrt();
            assert!(
                (r.outputs[0] - exact).abs() < 1e-4,
                "z = {z}: {}",
                r.outputs[0]
            );
            assert_eq!(r.missing, None);
        } else if z > reach + 1e-3 {
            assert!(r.outputs[0].is_nan());
            let why = r.missing.as_deref().unwrap();
            assert!(
                why.contains("impact_time") && why.contains("occurrence 1"),
                "{why}"
            );
        }
    }
    let o = m.summary.output("impact_time").unwrap();
    assert!(
        hits > 5 && o.missing > 5,
        "{hits} hits, {} missing",
        o.missing
    );
    assert_eq!(o.count + o.missing, 40);
    assert_eq!(m.summary.failed, 0);
    assert_eq!(m.summary.output("final_height").unwrap().count, 40);
    assert!(o.mean.is_finite() && o.sd > 0.0);
    let text = m.summary.to_string();
    assert!(
        text.contains(&format!("impact_time: {} of 40 samples", o.missing)),
        "{text}"
    );
}
