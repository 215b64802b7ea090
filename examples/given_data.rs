//! The given-data sensitivity measures on the Ishigami function: the rank estimator's
//! first-order indices and their interval coverage over many seeds, and HSIC's R² and
//! p-values, including an input the function ignores. The figures of docs/tolerancing.md.
//!
//! Run: cargo run --release --example given_data [seeds, default 200]

use mc_study::reliability::normal::keyed_unit;
use mc_study::study::given_data::{dependence, first_order};

fn ishigami(x: &[f64]) -> f64 {
    x[0].sin() + 7.0 * x[1].sin().powi(2) + 0.1 * x[2].powi(4) * x[0].sin()
}

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .map_or(200, |s| s.parse().expect("a number of seeds"));
    let pi = std::f64::consts::PI;
    let exact = [0.3139, 0.4424, 0.0];
    for n in [1024u64, 4096] {
        let mut hits = [0usize; 3];
        let mut mean = [0.0; 3];
        let mut width = [0.0; 3];
        let mut p = [0.0; 4];
        let mut r2 = [0.0; 4];
        for seed in 0..seeds {
            let x: Vec<[f64; 4]> = (0..n)
                .map(|i| [0, 1, 2, 3].map(|j| -pi + 2.0 * pi * keyed_unit(&[seed, i, j])))
                .collect();
            let y: Vec<f64> = x.iter().map(|r| ishigami(r)).collect();
            let cols: Vec<Vec<f64>> = (0..4).map(|j| x.iter().map(|r| r[j]).collect()).collect();
            for j in 0..3 {
                let e = first_order(&cols[j], &y);
                hits[j] += usize::from(e.ci95.0 <= exact[j] && exact[j] <= e.ci95.1);
                mean[j] += e.value / seeds as f64;
                width[j] += (e.ci95.1 - e.ci95.0) / seeds as f64;
            }
            if seed < 20 {
                let h = dependence(&cols, &y, seed).expect("enough rows");
                for j in 0..4 {
                    p[j] += h[j].p_value / 20.0;
                    r2[j] += h[j].r2 / 20.0;
                }
            }
        }
        println!("n = {n}, {seeds} seeds (i.i.d. uniform inputs):");
        for j in 0..3 {
            println!(
                "  S{} exact {:.4}: mean estimate {:.4}, mean interval width {:.4}, coverage {:.3}",
                j + 1,
                exact[j],
                mean[j],
                width[j],
                hits[j] as f64 / seeds as f64
            );
        }
        for j in 0..4 {
            println!(
                "  HSIC x{}{}: mean R² {:.4}, mean p {:.3} (20 seeds)",
                j + 1,
                if j == 3 {
                    " (ignored by the function)"
                } else {
                    ""
                },
                r2[j],
                p[j]
            );
        }
    }
}
