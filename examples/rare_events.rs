//! The rare-event estimators on closed forms, over many seeds: mean simulations, mean
//! estimate against the truth, empirical and reported coefficients of variation, interval
//! coverage, and which stage gave the number. The same cases as
//! benches/peers/openturns_rare_events.py, for the comparison in docs/reliability.md.
//!
//! Run: cargo run --release --example rare_events [seeds, default 100]

use mc_study::reliability::batch::Function;
use mc_study::reliability::{normal, run, Estimate, Method, Progress, Settings};
use statrs::distribution::{ChiSquared, ContinuousCDF};

/// A closed form: name, dimension, margin, exact probability, samples per level.
type Case<'a> = (&'a str, usize, Box<dyn Fn(&[f64]) -> f64>, f64, usize);

fn estimate(s: &Settings, d: usize, g: &dyn Fn(&[f64]) -> f64) -> Estimate {
    match run(s, d, &mut Function(g)) {
        Progress::Done(e) => *e,
        Progress::Needs(_) => unreachable!("a function answers every batch"),
    }
}

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .map_or(100, |s| s.parse().expect("a number of seeds"));
    let chi = ChiSquared::new(7.0).unwrap();
    let (mut lo, mut hi) = (0.0, 400.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if chi.sf(mid) > 1e-5 {
            lo = mid
        } else {
            hi = mid
        }
    }
    let c2 = 0.5 * (lo + hi);
    let linear = |d: usize| move |u: &[f64]| 4.753 - u.iter().sum::<f64>() / (d as f64).sqrt();
    let cases: Vec<Case> = vec![
        (
            "linear 7-d",
            7,
            Box::new(linear(7)),
            normal::cdf(-4.753),
            300,
        ),
        (
            "linear 50-d",
            50,
            Box::new(linear(50)),
            normal::cdf(-4.753),
            500,
        ),
        (
            "series 7-d",
            7,
            Box::new(|u: &[f64]| (4.5 - u[0]).min(4.5 - u[1]).min(4.5 - u[2])),
            1.0 - normal::cdf(4.5).powi(3),
            1000,
        ),
        (
            "chi-square 7-d",
            7,
            Box::new(move |u: &[f64]| c2 - u.iter().map(|x| x * x).sum::<f64>()),
            1e-5,
            1000,
        ),
    ];
    println!("{seeds} seeds per row");
    for (name, d, g, truth, n) in &cases {
        for importance in [true, false] {
            let runs: Vec<Estimate> = (0..seeds)
                .map(|seed| {
                    let s = Settings {
                        importance,
                        ..Settings::new(Method::Subset, *n, 0.1, seed)
                    };
                    estimate(&s, *d, g.as_ref())
                })
                .collect();
            let k = runs.len() as f64;
            let p: Vec<f64> = runs.iter().map(|e| e.probability).collect();
            let mean = p.iter().sum::<f64>() / k;
            let cov = (p.iter().map(|x| (x - truth).powi(2)).sum::<f64>() / k).sqrt() / truth;
            let reported = (runs.iter().map(|e| e.cov * e.cov).sum::<f64>() / k).sqrt();
            let sims = runs.iter().map(|e| e.simulations as f64).sum::<f64>() / k;
            let covered = runs
                .iter()
                .filter(|e| e.interval.0 <= *truth && *truth <= e.interval.1)
                .count() as f64
                / k;
            let is = runs.iter().filter(|e| e.stage == "importance").count() as f64 / k;
            println!(
                "{name:15} N={n:<5} {:22} sims {sims:7.0}  mean/truth {:6.3}  CoV empirical {cov:6.3} reported {reported:6.3}  coverage {covered:5.2}  importance final {:4.0} %",
                if importance { "subset + importance" } else { "subset only" },
                mean / truth,
                100.0 * is
            );
        }
    }
}
