//! The Rust side of the Python `evaluate` benchmark (python/benchmarks/evaluate_overhead.py):
//! `Subject::run` over the rows of a file of little-endian f64 (n × d), on one thread, as
//! `evaluate` calls it; prints the seconds per row. Usage:
//! `cargo run --release --example evaluate_rows -- SCENE X.bin PATH...`

use mc_study::study::sample_run::Subject;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [scene, rows, paths @ ..] = args.as_slice() else {
        eprintln!("usage: evaluate_rows SCENE X.bin PATH...");
        std::process::exit(2);
    };
    let text = std::fs::read_to_string(scene).expect("scene");
    let subject = Subject::from_yaml(&text, scene).unwrap_or_else(|e| panic!("{e}"));
    let x: Vec<f64> = std::fs::read(rows)
        .expect("rows")
        .chunks_exact(8)
        .map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes")))
        .collect();
    let d = paths.len();
    let selected: Vec<usize> = (0..subject.outputs().len()).collect();
    let start = Instant::now();
    let mut sum = 0.0;
    for row in x.chunks_exact(d) {
        let parameters: Vec<(&str, f64)> = paths
            .iter()
            .map(String::as_str)
            .zip(row.iter().copied())
            .collect();
        sum += subject.run(&parameters, &selected).outputs[0];
    }
    let n = x.len() / d;
    println!(
        "{:e} s/row over {n} rows (sum {sum:e})",
        start.elapsed().as_secs_f64() / n as f64
    );
}
