//! The extremes matrix of the clearance pendulum (clearance × step × friction), printed as a
//! Markdown table: `cargo run --release --example clearance_extremes`. The test suite runs
//! a smaller matrix (tests/clearance.rs); this is the full one.

use mc_study::scene::Scene;
use std::path::Path;
use std::time::Instant;

fn main() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/pendulum-clearance/scene.yaml");
    println!(
        "| c | h (s) | simulated (s) | μ | max penetration (m) | solver failures | NaN | µs/step |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (c, label) in [
        (1e-6, "1 µm"),
        (1e-5, "10 µm"),
        (7e-5, "70 µm"),
        (1e-3, "1 mm"),
    ] {
        for (h, t) in [(1e-6, 0.05), (1e-5, 0.5), (1e-4, 1.0)] {
            for mu in [0.0, 0.3, 1.0] {
                let mut scene = Scene::load(&path).expect("bundled scene");
                scene.set_parameter("joints.pivot.clearance", c).unwrap();
                scene.set_parameter("joints.pivot.mu", mu).unwrap();
                scene.params.h = h;
                let mut sim = scene.simulation().unwrap();
                let start = Instant::now();
                let result = sim.run_until(t, |_, _| {});
                let us = start.elapsed().as_secs_f64() * 1e6 / sim.stats.steps.max(1) as f64;
                let st = sim.stats;
                let nan = if result.is_err() { "yes" } else { "no" };
                println!(
                    "| {label} | {h:e} | {t} | {mu} | {:.2e} | {} | {nan} | {us:.1} |",
                    st.max_penetration,
                    st.solver_failures + st.newton_failures + st.projection_failures
                );
            }
        }
    }
}
