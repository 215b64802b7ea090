//! Rare-event estimators against closed forms, over many seeds: the estimate, the
//! coverage of its 95 % interval, and its reported coefficient of variation against the
//! spread actually seen.

use mc_study::reliability::batch::Function;
use mc_study::reliability::{normal, run, Estimate, Method, Progress, Settings};

fn estimate(settings: &Settings, d: usize, g: impl Fn(&[f64]) -> f64) -> Estimate {
    match run(settings, d, &mut Function(g)) {
        Progress::Done(e) => *e,
        Progress::Needs(_) => unreachable!("a function answers every batch"),
    }
}

/// Over `seeds` runs: the share of intervals that cover `truth`, the empirical CoV, the
/// mean reported CoV, the mean simulations, and how often each stage gave the number.
struct Campaign {
    coverage: f64,
    empirical_cov: f64,
    reported_cov: f64,
    simulations: f64,
    importance_share: f64,
    mean: f64,
}

fn campaign(
    seeds: u64,
    truth: f64,
    settings: impl Fn(u64) -> Settings,
    d: usize,
    g: impl Fn(&[f64]) -> f64 + Copy,
) -> Campaign {
    let runs: Vec<Estimate> = (0..seeds).map(|s| estimate(&settings(s), d, g)).collect();
    let n = runs.len() as f64;
    let p: Vec<f64> = runs.iter().map(|e| e.probability).collect();
    let mean = p.iter().sum::<f64>() / n;
    let rmse = (p.iter().map(|x| (x - truth).powi(2)).sum::<f64>() / n).sqrt();
    Campaign {
        coverage: runs
            .iter()
            .filter(|e| e.interval.0 <= truth && truth <= e.interval.1)
            .count() as f64
            / n,
        empirical_cov: rmse / truth,
        // the root mean square, which the mean squared relative error is to match when
        // runs report different CoVs (as when some fall back on subset simulation)
        reported_cov: (runs.iter().map(|e| e.cov * e.cov).sum::<f64>() / n).sqrt(),
        simulations: runs.iter().map(|e| e.simulations as f64).sum::<f64>() / n,
        importance_share: runs.iter().filter(|e| e.stage == "importance").count() as f64 / n,
        mean,
    }
}

fn linear(beta: f64) -> impl Fn(&[f64]) -> f64 + Copy {
    move |u: &[f64]| beta - u.iter().sum::<f64>() / (u.len() as f64).sqrt()
}

fn subset_settings(n: usize, seed: u64) -> Settings {
    Settings::new(Method::Subset, n, 0.1, seed)
}

fn report(name: &str, c: &Campaign, truth: f64) {
    eprintln!(
        "{name}: mean {:.4e} (truth {truth:.4e}), coverage {:.2}, CoV empirical {:.3} reported {:.3}, {:.0} simulations, importance final in {:.0} %",
        c.mean, c.coverage, c.empirical_cov, c.reported_cov, c.simulations, 100.0 * c.importance_share
    );
}

/// The checks every closed form must pass: 95 % intervals cover in 90–99 % of runs (for
/// 100 seeds), and the reported CoV is within a factor 1.5 of the spread seen.
fn check(name: &str, c: &Campaign, truth: f64) {
    report(name, c, truth);
    assert!(
        (0.90..=0.99).contains(&c.coverage)
            || (c.coverage == 1.0 && c.empirical_cov < 0.5 * c.reported_cov),
        "{name}: coverage {}",
        c.coverage
    );
    let ratio = c.empirical_cov / c.reported_cov;
    assert!(
        (1.0 / 1.5..=1.5).contains(&ratio),
        "{name}: empirical CoV {} against reported {}",
        c.empirical_cov,
        c.reported_cov
    );
}

/// χ²_d upper quantile: the c with P(χ²_d ≥ c) = p, by bisection on statrs' survival.
fn chi2_quantile_upper(d: usize, p: f64) -> f64 {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    let chi = ChiSquared::new(d as f64).unwrap();
    let (mut lo, mut hi) = (0.0, 400.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if chi.sf(mid) > p {
            lo = mid
        } else {
            hi = mid
        }
    }
    0.5 * (lo + hi)
}

#[test]
fn linear_7d_at_one_in_a_million() {
    let truth = normal::cdf(-4.753);
    let c = campaign(100, truth, |s| subset_settings(300, s), 7, linear(4.753));
    check("linear 7-d", &c, truth);
    // importance sampling gives the number, and meets the target in about 3,000 runs
    assert!(c.importance_share >= 0.95, "{}", c.importance_share);
    assert!(c.simulations <= 3300.0, "{} simulations", c.simulations);
    assert!(c.empirical_cov <= 0.11, "empirical CoV {}", c.empirical_cov);
}

#[test]
fn linear_50d_at_one_in_a_million() {
    let truth = normal::cdf(-4.753);
    let c = campaign(100, truth, |s| subset_settings(500, s), 50, linear(4.753));
    check("linear 50-d", &c, truth);
    assert!(c.importance_share >= 0.9, "{}", c.importance_share);
}

#[test]
fn chi_square_tail_falls_back_on_subset_simulation() {
    // failure |u|² ≥ c in 7-d: a boundary curved around the origin, which one shifted
    // normal cannot cover; subset simulation's number stands
    let d = 7;
    let c2 = chi2_quantile_upper(d, 1e-5);
    let g = move |u: &[f64]| c2 - u.iter().map(|x| x * x).sum::<f64>();
    let c = campaign(100, 1e-5, |s| subset_settings(1000, s), d, g);
    check("chi-square 7-d", &c, 1e-5);
    assert!(c.importance_share <= 0.05, "{}", c.importance_share);
}

#[test]
fn series_system_of_three_parts() {
    // max of three orthogonal linear margins: P = 1 − Φ(4.5)³ = 1.01930e-5
    let truth = 1.0 - normal::cdf(4.5).powi(3);
    assert!((truth / 1.01930e-5 - 1.0).abs() < 1e-4);
    let g = |u: &[f64]| (4.5 - u[0]).min(4.5 - u[1]).min(4.5 - u[2]);
    let c = campaign(100, truth, |s| subset_settings(1000, s), 7, g);
    check("series 7-d", &c, truth);
}

#[test]
fn two_separate_parts_are_both_counted() {
    // failure at u₁ ≥ 4.5 or u₁ ≤ −4.5: two half-spaces on opposite sides, P = 2 Φ(−4.5)
    let truth = 2.0 * normal::cdf(-4.5);
    let g = |u: &[f64]| 4.5 - u[0].abs();
    let c = campaign(100, truth, |s| subset_settings(2000, s), 5, g);
    report("two parts 5-d", &c, truth);
    // Both parts are found: an estimate that found one only would sit near half the
    // truth. Chains that cross between the parts spread the estimate wider than Au &
    // Beck's CoV says (empirical 0.74 against 0.44 reported): the interval covers in
    // about 89 % of runs, below the 95 % it claims, as docs/reliability.md says.
    assert!(
        (c.mean / truth - 1.0).abs() < 0.25,
        "mean {} against {truth}",
        c.mean
    );
    assert!(c.coverage >= 0.85, "coverage {}", c.coverage);
    assert!(c.empirical_cov / c.reported_cov < 2.0);
}

#[test]
fn plain_monte_carlo_reference() {
    // P = Φ(−2.5) = 6.21e-3: direct sampling to a CoV of 0.1 needs about 16,000 runs
    let truth = normal::cdf(-2.5);
    let c = campaign(
        100,
        truth,
        |s| Settings::new(Method::MonteCarlo, 2000, 0.1, s),
        3,
        linear(2.5),
    );
    check("monte-carlo 3-d", &c, truth);
}

#[test]
fn same_seed_same_bits_other_seed_other_bits() {
    let s = subset_settings(300, 42);
    let a = estimate(&s, 7, linear(4.753));
    let b = estimate(&s, 7, linear(4.753));
    assert_eq!(a.probability.to_bits(), b.probability.to_bits());
    assert_eq!(a.simulations, b.simulations);
    let c = estimate(&subset_settings(300, 43), 7, linear(4.753));
    assert_ne!(a.probability.to_bits(), c.probability.to_bits());
}

#[test]
fn replay_stops_at_the_first_missing_batch() {
    // the runner's view: margins known for the first k batches only; the request it gets
    // is the same whatever was stored after it
    use mc_study::reliability::batch::{Margins, Request};
    struct Known(usize, usize);
    impl Margins for Known {
        fn of(&mut self, r: &Request) -> Option<Vec<f64>> {
            self.1 += 1;
            (self.1 <= self.0).then(|| r.points.iter().map(|u| linear(4.753)(u)).collect())
        }
    }
    let s = subset_settings(300, 5);
    let full = estimate(&s, 7, linear(4.753));
    let mut first_ids = Vec::new();
    for k in 0..60 {
        match run(&s, 7, &mut Known(k, 0)) {
            Progress::Needs(r) => {
                assert_eq!(r.tags[0].batch, k as u64);
                assert_eq!(r.points.len(), r.tags.len());
                first_ids.push(r.first);
            }
            Progress::Done(e) => {
                assert_eq!(e.probability.to_bits(), full.probability.to_bits());
                assert_eq!(e.simulations, *first_ids.last().unwrap() + 300);
                return;
            }
        }
    }
    panic!("the estimate did not finish in 60 batches");
}
