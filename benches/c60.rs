//! Wall time per sample of the circuit-breaker study (`studies/c60/`) at its default
//! fidelity, one core: `c60/nominal` (all clearances 0.07 mm) and `c60/sample-<i>`
//! (samples 0–1 of the study's design), each a full latched + trip simulation with its
//! probes. `c60/rebuild` is the part of a sample that writes its seven clearances into the
//! scene document and rebuilds, validates and assembles the scene: it must stay below 1 %
//! of a sample.
//!
//! Run: `cargo bench --bench c60`.

use criterion::{criterion_group, criterion_main, Criterion};
use mc_study::study::Study;
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

fn per_sample(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/c60/study.yaml");
    let study = Study::load(&path, None).unwrap();
    let all: Vec<usize> = study.outputs.iter().map(|o| o.index).collect();
    let mut g = c.benchmark_group("c60");
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(10));
    g.bench_function("nominal", |b| {
        b.iter(|| {
            let o = study.subject.run(&[], &all);
            assert!(o.error.is_none(), "{:?}", o.error);
            black_box(o)
        })
    });
    for i in 0..2 {
        g.bench_function(format!("sample-{i}"), |b| {
            b.iter(|| {
                let (_, o) = study.run_sample(i);
                assert!(o.error.is_none(), "{:?}", o.error);
                black_box(o)
            })
        });
    }
    g.finish();
    let mc_study::study::Subject::Mechanism(scene) = &study.subject else {
        unreachable!("c60 is a mechanism")
    };
    let x = study.inputs(0);
    let values: Vec<(&str, f64)> = study
        .parameters
        .iter()
        .map(|p| p.path.as_str())
        .zip(x)
        .collect();
    c.bench_function("c60/rebuild", |b| {
        b.iter(|| black_box(scene.with_parameters(&values).unwrap()))
    });
}

criterion_group!(benches, per_sample);
criterion_main!(benches);
