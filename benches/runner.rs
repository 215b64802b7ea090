//! The study runner's own cost, measured on scenes where the simulation costs little:
//! - `runner/ishigami-*`: per-sample time of a whole run (design, inverse CDFs, channel,
//!   writer, Parquet parts, manifest) on the closed-form Ishigami scene, against the same
//!   samples evaluated directly; the difference is the runner's overhead per sample;
//! - `threads/bouncing-ball-*`: samples/s of the bouncing-ball study at 1 and 2 worker
//!   threads (parallel efficiency).
//!
//! Criterion reports time per element = per sample. Run: `cargo bench --bench runner`.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use mc_study::study::runner::{run, RunOptions};
use mc_study::study::Study;
use std::hint::black_box;
use std::path::{Path, PathBuf};

fn study(name: &str, samples: u64) -> Study {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("studies")
        .join(name)
        .join("study.yaml");
    Study::load(&p, Some(samples)).unwrap()
}

fn fresh(label: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("mc-study-bench-{label}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn options(out: PathBuf, threads: usize) -> RunOptions {
    let mut o = RunOptions::new(out);
    o.threads = Some(threads);
    o.progress = false;
    o
}

fn overhead(c: &mut Criterion) {
    let n = 20_000;
    let s = study("ishigami", n);
    let mut g = c.benchmark_group("runner");
    g.throughput(Throughput::Elements(n));
    g.sample_size(10);
    g.bench_function("ishigami-direct", |b| {
        b.iter(|| {
            for i in 0..n {
                black_box(s.run_sample(i));
            }
        })
    });
    g.bench_function("ishigami-run", |b| {
        b.iter_batched(
            || fresh("ishigami"),
            |out| run(&s, &options(out, 1)).unwrap(),
            BatchSize::PerIteration,
        )
    });
    g.finish();
}

fn threads(c: &mut Criterion) {
    let n = 48;
    let s = study("bouncing-ball", n);
    let mut g = c.benchmark_group("threads");
    g.throughput(Throughput::Elements(n));
    g.sample_size(10);
    for t in [1, 2] {
        g.bench_function(format!("bouncing-ball-{t}"), |b| {
            b.iter_batched(
                || fresh("ball"),
                |out| run(&s, &options(out, t)).unwrap(),
                BatchSize::PerIteration,
            )
        });
    }
    g.finish();
}

criterion_group!(benches, overhead, threads);
criterion_main!(benches);
