//! Tolerance decisions against closed forms: correlated inputs (rank correlation within
//! its standard error, marginals unchanged), the linear stack-up (σ exact on a linear
//! stack, R² telling a nonlinear one), given-data sensitivity (Ishigami), the worst case
//! on a mechanism against a dense grid, and allocation against the Lagrange solution.

mod common;

use mc_study::study::given_data::{dependence, first_order, rank_first_order};
use mc_study::study::runner::RunOptions;
use mc_study::study::statistics::spearman;
use mc_study::study::Study;
use mc_study::tolerancing::allocation_run::{allocate, Ended};
use mc_study::tolerancing::stack_up::stack_up;
use mc_study::tolerancing::worst_case::Settings;
use mc_study::tolerancing::worst_case_run;
use std::path::{Path, PathBuf};

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data")
}

fn study(text: &str) -> Result<Study, String> {
    Study::from_yaml(text, "t.yaml", &data(), None).map_err(|e| e.to_string())
}

fn correlated(design: &str, seed: u64, n: u64, correlation: &str) -> Study {
    study(&format!(
        "name: c\nscene: linear.yaml\nsamples: {n}\nseed: {seed}\ndesign: {design}\nparameters:\n  - {{ path: inputs.x1, distribution: {{ normal: {{ mean: 2, sd: 0.5 }} }} }}\n  - {{ path: inputs.x2, distribution: {{ uniform: {{ lower: 0, upper: 1 }} }} }}\n  - {{ path: inputs.x3, distribution: {{ normal: {{ mean: 0, sd: 1 }} }} }}\ncorrelations:\n  - {{ between: [inputs.x1, inputs.x2], {correlation} }}\n"
    ))
    .unwrap()
}

/// The Kolmogorov–Smirnov distance of a sample to a CDF.
fn ks(mut x: Vec<f64>, cdf: impl Fn(f64) -> f64) -> f64 {
    x.sort_by(f64::total_cmp);
    let n = x.len() as f64;
    x.iter()
        .enumerate()
        .map(|(i, &v)| {
            let f = cdf(v);
            (f - i as f64 / n).abs().max(((i + 1) as f64 / n - f).abs())
        })
        .fold(0.0, f64::max)
}

#[test]
fn a_rank_correlation_holds_under_lhs_and_sobol_with_the_marginals_unchanged() {
    let n = 4096u64;
    // Spearman's ρ has standard error ≈ (1 − ρ²) √(1.06 / (n − 3)) (Fieller et al. 1957)
    let se = (1.0 - 0.64) * (1.06 / (n as f64 - 3.0)).sqrt();
    let ks_1pc = 1.63 / (n as f64).sqrt();
    for design in ["lhs", "sobol"] {
        let mut sq = 0.0;
        let seeds = 1..=8u64;
        for seed in seeds.clone() {
            let s = correlated(design, seed, n, "rank: 0.8");
            let x: Vec<Vec<f64>> = (0..n).map(|i| s.inputs(i)).collect();
            let col = |j: usize| x.iter().map(|r| r[j]).collect::<Vec<f64>>();
            let r = spearman(&col(0), &col(1));
            assert!((r - 0.8).abs() < 4.0 * se, "{design} seed {seed}: ρₛ {r}");
            sq += (r - 0.8).powi(2);
            let normal =
                |m: f64, sd: f64| move |v: f64| mc_study::reliability::normal::cdf((v - m) / sd);
            assert!(
                ks(col(0), normal(2.0, 0.5)) < ks_1pc,
                "{design}: x1's marginal"
            );
            assert!(
                ks(col(1), |v| v.clamp(0.0, 1.0)) < ks_1pc,
                "{design}: x2's marginal"
            );
            assert!(
                ks(col(2), normal(0.0, 1.0)) < ks_1pc,
                "{design}: x3's marginal"
            );
            // an uncorrelated input stays uncorrelated
            assert!(spearman(&col(0), &col(2)).abs() < 4.0 / (n as f64).sqrt());
        }
        let rms = (sq / seeds.count() as f64).sqrt();
        // a wrong conversion (ρ = ρₛ) would leave ρₛ = 0.786, 2.4 standard errors off
        assert!(rms < 1.5 * se, "{design}: rms error {rms} against se {se}");
    }
}

#[test]
fn a_linear_correlation_between_unlike_marginals_uses_the_nataf_equation() {
    let n = 20_000u64;
    let s = correlated("random", 3, n, "linear: 0.6");
    let x: Vec<Vec<f64>> = (0..n).map(|i| s.inputs(i)).collect();
    let col = |j: usize| x.iter().map(|r| r[j]).collect::<Vec<f64>>();
    let r = mc_study::study::statistics::pearson(&col(0), &col(1));
    let se = (1.0 - 0.36) / (n as f64).sqrt();
    assert!((r - 0.6).abs() < 4.0 * se, "Pearson {r}");
    // a normal and a uniform of correlated scores correlate √(3/π) times less
    let expected = 0.6 / (3.0 / std::f64::consts::PI).sqrt();
    assert!((s.copula.scores[(0, 1)] - expected).abs() < 1e-3);
}

#[test]
fn bad_correlations_costs_and_targets_are_refused_with_their_field() {
    let base = "name: c\nscene: linear.yaml\nsamples: 10\nparameters:\n  - { path: inputs.x1, tolerance: { nominal: 1, plus_minus: 0.1 } }\n  - { path: inputs.x2, distribution: { normal: { mean: 0, sd: 1 } } }\n  - { path: inputs.x3, distribution: { normal: { mean: 0, sd: 1 } } }\n";
    let err = |extra: &str| study(&format!("{base}{extra}")).unwrap_err();
    let e = err("correlations:\n  - { between: [inputs.x1, inputs.x9], rank: 0.5 }\n");
    assert!(
        e.contains("t.yaml:9:")
            && e.contains("correlations[0].between[1]")
            && e.contains("inputs.x9"),
        "{e}"
    );
    let e = err("correlations:\n  - { between: [inputs.x1, inputs.x2], rank: 0.9 }\n  - { between: [inputs.x1, inputs.x3], rank: 0.9 }\n  - { between: [inputs.x2, inputs.x3], rank: -0.9 }\n");
    assert!(
        e.contains("correlations[2]")
            && e.contains("`inputs.x2`–`inputs.x3`")
            && e.contains("positive definite"),
        "{e}"
    );
    let e = err("correlations:\n  - { between: [inputs.x1, inputs.x2], rank: 1.2 }\n");
    assert!(
        e.contains("correlations[0].rank") && e.contains("(−1, 1)"),
        "{e}"
    );
    let e = err("correlations:\n  - { between: [inputs.x1, inputs.x1], rank: 0.2 }\n");
    assert!(e.contains("the same parameter twice"), "{e}");
    let e = study(&base.replace("plus_minus: 0.1", "plus_minus: -0.1")).unwrap_err();
    assert!(
        e.contains("parameters[0].tolerance.plus_minus") && e.contains("≥ 0"),
        "{e}"
    );
    let e = study(&base.replace("plus_minus: 0.1 }", "plus_minus: 0.1, cp: 0 }")).unwrap_err();
    assert!(
        e.contains("parameters[0].tolerance.cp") && e.contains("> 0"),
        "{e}"
    );
    let e = study(&base.replace(
        "plus_minus: 0.1 } }",
        "plus_minus: 0.1 }, cost: { b: -2 } }",
    ))
    .unwrap_err();
    assert!(
        e.contains("parameters[0].cost.b") && e.contains("> 0"),
        "{e}"
    );
    let e = err("allocation: { cpk: 1.33 }\n");
    assert!(e.contains("allocation") && e.contains("limits"), "{e}");
    let e = err("limits:\n  - { output: y, upper: 3 m }\nallocation: { cpk: -1 }\n");
    assert!(e.contains("allocation.cpk"), "{e}");
}

/// The linear stack's study (tests/data/tolerance-study.yaml) with `n` samples.
fn stack(n: u64) -> Study {
    Study::load(&data().join("tolerance-study.yaml"), Some(n)).unwrap()
}

#[test]
fn rss_reproduces_the_closed_form_sigma_of_a_linear_stack_and_flags_a_bent_one() {
    let s = stack(500);
    let runs: Vec<(Vec<f64>, Vec<f64>)> = (0..500)
        .map(|i| {
            let (x, o) = s.run_sample(i);
            (x, o.outputs)
        })
        .collect();
    let x: Vec<Vec<f64>> = (0..4)
        .map(|j| runs.iter().map(|r| r.0[j]).collect())
        .collect();
    let y: Vec<f64> = runs.iter().map(|r| r.1[0]).collect();
    let st = stack_up(&s, "y", &x, &y, 3.0).unwrap();
    // σᵢ = tᵢ / 3 at Cp 1: σ² = Σ aᵢ² tᵢ² / 9
    let a = [1.5, -2.0, 0.5, 3.0];
    let t = [0.1, 0.05, 0.2, 0.02];
    let var: f64 = a.iter().zip(t).map(|(a, t)| a * a * t * t / 9.0).sum();
    assert!(
        (st.sigma / var.sqrt() - 1.0).abs() < 1e-9,
        "σ {} against {}",
        st.sigma,
        var.sqrt()
    );
    for j in 0..4 {
        assert!((st.sensitivities[j] - a[j]).abs() < 1e-9);
        let share = 100.0 * a[j] * a[j] * t[j] * t[j] / 9.0 / var;
        assert!((st.contributions[j] - share).abs() < 1e-6);
    }
    assert!(st.r2 > 1.0 - 1e-12 && st.trusted());
    // nominal 11, linear worst case 11 ± Σ |aᵢ| tᵢ
    let half: f64 = a.iter().zip(t).map(|(a, t)| a.abs() * t).sum();
    assert!((st.linear_worst_case.1 - (11.0 + half)).abs() < 1e-9);
    // 100 (a − 10)² + d: the square has no linear part
    let y: Vec<f64> = runs.iter().map(|r| r.1[1]).collect();
    let bent = stack_up(&s, "bent", &x, &y, 3.0).unwrap();
    assert!(bent.r2 < 0.5 && !bent.trusted(), "R² {}", bent.r2);
}

fn ishigami(x: &[f64]) -> f64 {
    x[0].sin() + 7.0 * x[1].sin().powi(2) + 0.1 * x[2].powi(4) * x[0].sin()
}

#[test]
fn given_data_indices_of_ishigami_from_4096_lhs_samples() {
    let text = std::fs::read_to_string(common::study_path("ishigami", "study.yaml"))
        .unwrap()
        .replace("design: sobol", "design: lhs");
    let s = Study::from_yaml(
        &text,
        "study.yaml",
        &common::study_path("ishigami", ""),
        None,
    )
    .unwrap();
    let n = 4096;
    let x: Vec<Vec<f64>> = (0..n).map(|i| s.inputs(i)).collect();
    let y: Vec<f64> = (0..n).map(|i| s.run_sample(i).1.outputs[0]).collect();
    for (j, exact) in [0.3139, 0.4424, 0.0].into_iter().enumerate() {
        let xj: Vec<f64> = x.iter().map(|r| r[j]).collect();
        let e = first_order(&xj, &y);
        eprintln!(
            "S{} = {:.4} [{:.4}, {:.4}]",
            j + 1,
            e.value,
            e.ci95.0,
            e.ci95.1
        );
        assert!(
            (e.value - exact).abs() < 0.05,
            "S{} = {} against {exact}",
            j + 1,
            e.value
        );
        assert!(e.ci95.0 < e.value && e.value < e.ci95.1);
    }
    // HSIC sees x3, which acts only through its interaction with x1, and not a dummy
    let mut cols: Vec<Vec<f64>> = (0..3).map(|j| x.iter().map(|r| r[j]).collect()).collect();
    cols.push((0..n).map(|i| ((i * 7919) % 4096) as f64).collect());
    let h = dependence(&cols, &y, 1).unwrap();
    assert!(h[2].p_value <= 0.02 && h[2].r2 > 0.01, "{:?}", h[2]);
    assert!(h[3].p_value > 0.05 && h[3].r2 < h[2].r2, "{:?}", h[3]);
}

#[test]
fn the_rank_estimators_interval_covers_the_exact_index() {
    // i.i.d. Ishigami samples in memory, 200 seeds
    use mc_study::reliability::normal::keyed_unit;
    let pi = std::f64::consts::PI;
    let n = 2048u64;
    let (mut hits, mut total) = (0, 0);
    for seed in 0..200u64 {
        let x: Vec<[f64; 3]> = (0..n)
            .map(|i| [0, 1, 2].map(|j| -pi + 2.0 * pi * keyed_unit(&[seed, i, j])))
            .collect();
        let y: Vec<f64> = x.iter().map(|r| ishigami(r)).collect();
        for (j, exact) in [(0, 0.3139), (1, 0.4424)] {
            let xj: Vec<f64> = x.iter().map(|r| r[j]).collect();
            let e = first_order(&xj, &y);
            hits += usize::from(e.ci95.0 <= exact && exact <= e.ci95.1);
            total += 1;
        }
    }
    let cover = hits as f64 / total as f64;
    assert!((0.88..=0.99).contains(&cover), "coverage {cover}");
    // a constant output has no index
    assert!(rank_first_order(&[1.0, 2.0, 3.0], &[5.0, 5.0, 5.0]).is_nan());
}

fn options(out: &Path, threads: usize) -> RunOptions {
    let mut o = RunOptions::new(out.to_path_buf());
    o.threads = Some(threads);
    o.progress = false;
    o
}

#[test]
fn the_worst_case_of_a_four_bar_agrees_with_a_dense_grid() {
    let s = Study::load(&data().join("four-bar-worst-case.yaml"), None).unwrap();
    let dir = common::scratch("worst-case-four-bar");
    let settings = Settings::default();
    let wc = worst_case_run::run(&s, &[0, 1], &settings, 3.0, &options(&dir, 2))
        .unwrap()
        .unwrap();
    let boxes = worst_case_run::boxes(&s, 3.0);
    assert!((boxes[0].0 - 0.014).abs() < 1e-15 && (boxes[0].1 - 0.016).abs() < 1e-15);
    let g = 20;
    let mut grid: Vec<Vec<f64>> = Vec::new();
    for i in 0..=g {
        for j in 0..=g {
            let at =
                |k: usize, t: usize| boxes[k].0 + (boxes[k].1 - boxes[k].0) * t as f64 / g as f64;
            grid.push(s.run_inputs(&[at(0, i), at(1, j)]).outputs);
        }
    }
    for (k, name) in s.outputs.iter().map(|o| &o.name).enumerate() {
        let values: Vec<f64> = grid.iter().map(|y| y[k]).collect();
        let (lo, hi) = values
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        let e = &wc.extremes[k];
        let (min, max) = (e.min.as_ref().unwrap().value, e.max.as_ref().unwrap().value);
        // the search reaches at least the grid's extremes, and not beyond them by more than
        // what the grid's spacing can hide
        let slack = 1e-3 * (hi - lo);
        assert!(
            max >= hi - 1e-9 * hi.abs() && max <= hi + slack,
            "{name}: max {max} against the grid's {hi}"
        );
        assert!(
            min <= lo + 1e-9 * lo.abs() && min >= lo - slack,
            "{name}: min {min} against the grid's {lo}"
        );
    }
    // resumed from the store, and run on one thread: the same bits without a new run
    let again = worst_case_run::run(&s, &[0, 1], &settings, 3.0, &options(&dir, 1))
        .unwrap()
        .unwrap();
    assert_eq!(
        serde_json::to_string(&again).unwrap(),
        serde_json::to_string(&wc).unwrap()
    );
    let other = common::scratch("worst-case-four-bar-1-thread");
    let single = worst_case_run::run(&s, &[0, 1], &settings, 3.0, &options(&other, 1))
        .unwrap()
        .unwrap();
    assert_eq!(
        serde_json::to_string(&single.extremes).unwrap(),
        serde_json::to_string(&wc.extremes).unwrap()
    );
}

#[test]
fn allocation_on_a_linear_stack_matches_the_lagrange_solution() {
    let dir = common::scratch("allocation-stack");
    let path = dir.join("tolerance-study.yaml");
    std::fs::copy(
        data().join("tolerance-stack.yaml"),
        dir.join("tolerance-stack.yaml"),
    )
    .unwrap();
    let text = std::fs::read_to_string(data().join("tolerance-study.yaml"))
        .unwrap()
        .replace("samples: 4000", "samples: 40000");
    std::fs::write(&path, text).unwrap();
    let s = Study::load(&path, None).unwrap();
    let target = s.allocation.clone().unwrap();
    let Ended::Done(a) =
        allocate(&s, &path, &target, &dir.join("results"), &options(&dir, 2)).unwrap()
    else {
        panic!("the stack's target can be met")
    };
    // tᵢ ∝ (cᵢ / aᵢ²)^(1/3) with cᵢ = bᵢ tᵢ⁰ the 1/t coefficient; scaled so that σ = s
    let coef = [1.5f64, -2.0, 0.5, 3.0];
    let t0 = [0.1, 0.05, 0.2, 0.02];
    let b = [1.0, 2.0, 0.5, 4.0];
    let shape: Vec<f64> = (0..4)
        .map(|i| (b[i] * t0[i] / (coef[i] * coef[i])).cbrt())
        .collect();
    let s_target = 0.25 / (3.0 * 1.33);
    let sigma_shape: f64 = (0..4)
        .map(|i| (coef[i] * shape[i] / 3.0).powi(2))
        .sum::<f64>()
        .sqrt();
    for i in 0..4 {
        let expected = shape[i] * s_target / sigma_shape;
        let got = a.ratios[i] * t0[i];
        assert!(
            (got / expected - 1.0).abs() < 0.01,
            "t{i} = {got} against {expected}"
        );
    }
    assert!(a.met, "{:?}", a.rounds.last().unwrap().confirmed);
    assert!(a.cost_after < a.cost_before);
    // the file written beside the study holds the allocation and runs as it is
    let written = Study::load(&a.file, Some(100)).unwrap();
    let d = written.parameters[3].drawing.as_ref().unwrap();
    assert!((d.plus / (a.ratios[3] * 0.02) - 1.0).abs() < 1e-3);
    assert_eq!(written.name, "tolerance-stack-allocated");
}

#[test]
fn allocation_on_a_four_bar_is_confirmed_and_an_impossible_target_is_reported() {
    let dir = common::scratch("allocation-four-bar");
    let path = dir.join("study.yaml");
    std::fs::copy(
        data().join("four-bar-links.yaml"),
        dir.join("four-bar-links.yaml"),
    )
    .unwrap();
    std::fs::write(
        &path,
        "name: four-bar-allocation\nscene: four-bar-links.yaml\nsamples: 256\nseed: 2\ndesign: lhs\nparameters:\n  - { path: joints.B.anchor_b.x, tolerance: { nominal: 15 mm, plus_minus: 0.1 mm, cp: 1 } }\n  - { path: joints.C.anchor_a.x, tolerance: { nominal: 55 mm, plus_minus: 0.1 mm, cp: 1 } }\n  - { path: joints.C.anchor_b.x, tolerance: { nominal: 40 mm, plus_minus: 0.1 mm, cp: 1 } }\n  - { path: joints.D.anchor_a.x, tolerance: { nominal: 120 mm, plus_minus: 0.2 mm, cp: 1 } }\noutputs: [rocker_max]\nlimits:\n  - { output: rocker_max, lower: 138.44 deg, upper: 138.74 deg }\nallocation: { cpk: 1.33 }\n",
    )
    .unwrap();
    let s = Study::load(&path, None).unwrap();
    let mut target = s.allocation.clone().unwrap();
    let Ended::Done(a) =
        allocate(&s, &path, &target, &dir.join("results"), &options(&dir, 2)).unwrap()
    else {
        panic!("the four-bar's target can be met")
    };
    let last = &a.rounds.last().unwrap().confirmed[0];
    assert!(
        a.met && last.interval.0 <= 1.33 && 1.33 <= last.interval.1 + 1e-12,
        "{last:?}"
    );
    // today's Cpk is about 1.04: tightening is needed, and the most sensitive link is cut
    assert!(a.ratios[3] < 1.0);
    // Cpk 20 needs σ below 1/20 of today's: beyond the narrowest ratio (0.1)
    target.cpk = 20.0;
    match allocate(&s, &path, &target, &dir.join("results"), &options(&dir, 2)).unwrap() {
        Ended::Infeasible {
            output,
            cpk_at_narrowest,
        } => {
            assert_eq!(output, "rocker_max");
            assert!(cpk_at_narrowest < 20.0);
        }
        _ => panic!("Cpk 20 cannot be met"),
    }
}

#[test]
fn the_commands_print_the_table_refuse_misuse_and_report_an_impossible_target() {
    let dir = common::scratch("tolerancing-commands");
    for f in ["tolerance-stack.yaml", "tolerance-study.yaml"] {
        std::fs::copy(data().join(f), dir.join(f)).unwrap();
    }
    let bin = env!("CARGO_BIN_EXE_mc-study");
    let run = |args: &[&str]| {
        std::process::Command::new(bin)
            .args(args)
            .current_dir(&dir)
            .output()
            .unwrap()
    };
    let out = run(&["run", "tolerance-study.yaml", "--out", "res", "--quiet"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = run(&[
        "worst-case",
        "tolerance-study.yaml",
        "--results",
        "res",
        "--quiet",
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // y = 1.5 a − 2 b + 0.5 c + 3 d: 11 ± 0.41 over the box, beyond the limits 11 ± 0.25
    assert!(text.contains("y min 10.590 m at a corner"), "{text}");
    assert!(
        text.contains("worst case (searched)   [10.590 m, 11.410 m]  BREAKS THE LIMITS"),
        "{text}"
    );
    assert!(
        text.contains("RSS, mean ± 3σ") && text.contains("R² 1.000"),
        "{text}"
    );
    assert!(
        text.contains("y contributors (RSS, R² 1.000): inputs.a 48.8 %"),
        "{text}"
    );
    // its runs are not a study to merge
    let out = run(&["merge", "res/worst-case"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("worst-case search"));
    // the report carries the table
    let out = run(&["report", "res"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let html = std::fs::read_to_string(dir.join("res/report/report.html")).unwrap();
    assert!(
        html.contains("Worst case, RSS and Monte Carlo") && html.contains("10 ±0.1 (normal, Cp 1)")
    );
    // Cpk 40 on y needs σ = 0.002, below what the narrowest tolerances give
    let out = run(&[
        "allocate",
        "tolerance-study.yaml",
        "--results",
        "res",
        "--cpk",
        "40",
        "--quiet",
    ]);
    assert_eq!(out.status.code(), Some(3));
    assert!(String::from_utf8_lossy(&out.stdout).contains("the target cannot be met: `y`"));
    let out = run(&["worst-case", "tolerance-study.yaml", "--output", "nope"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr)
        .contains("--output nope: not an output of the study (y, bent)"));
}
