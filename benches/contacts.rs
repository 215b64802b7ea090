//! Cost per step against the number of active contacts: n spheres (1 kg, radius 10 mm)
//! resting on the ground plane side by side, each in contact (n = 1 … 100 contacts), and
//! n boxes stacked on their corners (4n coupled contacts, the Delassus matrix no longer
//! block diagonal). Criterion reports time per step. Run: `cargo bench --bench contacts`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
#[path = "../tests/harness/extremes.rs"]
mod extremes;

use extremes::box_stack;
use mc_study::scene::Scene;
use std::hint::black_box;

const STEPS: u64 = 100;

fn resting_spheres(n: usize) -> Scene {
    let mut text = String::from(
        "name: spheres\nduration: 1 s\nintegrator: { h: 1 ms, scheme: combined-projection }\nbodies:\n",
    );
    for i in 0..n {
        text += &format!(
            "  - {{ name: s{i}, mass: 1 kg, shape: {{ sphere: {{ radius: 10 mm }} }}, position: [{}, 0, 10 mm] }}\n",
            0.03 * i as f64
        );
    }
    text += "contacts:\n";
    for i in 0..n {
        text += &format!(
            "  - {{ name: c{i}, body: s{i}, shape: {{ sphere: {{ radius: 10 mm }} }}, against: ground, against_shape: {{ plane: {{ point: [0, 0, 0], normal: [0, 0, 1] }} }}, mu: 0.3, e: 0 }}\n"
        );
    }
    Scene::from_yaml(&text, "spheres").unwrap()
}

fn bench(c: &mut Criterion, group: &str, n: usize, contacts: usize, s: &Scene) {
    let mut g = c.benchmark_group(group);
    g.throughput(Throughput::Elements(STEPS));
    g.sample_size(10);
    g.bench_with_input(BenchmarkId::from_parameter(contacts), &n, |b, _| {
        b.iter_batched(
            || {
                // start from the resting state, every contact active
                let mut sim = s.simulation().unwrap();
                for _ in 0..5 {
                    sim.step().unwrap();
                }
                sim
            },
            |mut sim| {
                for _ in 0..STEPS {
                    let r = sim.step().unwrap();
                    assert_eq!(r.active_contacts, contacts);
                }
                black_box(sim.state.t)
            },
            criterion::BatchSize::LargeInput,
        )
    });
    g.finish();
}

fn contacts(c: &mut Criterion) {
    for n in [1, 3, 10, 30, 100] {
        bench(c, "resting spheres (contacts)", n, n, &resting_spheres(n));
    }
    for n in [1, 2, 5, 10, 25] {
        bench(c, "stacked boxes (contacts)", n, 4 * n, &box_stack(n).scene);
    }
}

criterion_group!(benches, contacts);
criterion_main!(benches);
