//! Helpers shared by the integration tests.
#![allow(dead_code)]

use mc_study::integrator::Simulation;
use mc_study::scene::Scene;
use std::path::Path;

/// Loads a bundled scene from `studies/<name>/scene.yaml`.
pub fn bundled(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("studies")
        .join(name)
        .join("scene.yaml");
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

pub fn simulation(scene: Scene) -> Simulation {
    scene.simulation().expect("valid parameters")
}

/// Least-squares slope of log(err) against log(h).
pub fn loglog_slope(h: &[f64], err: &[f64]) -> f64 {
    let x: Vec<f64> = h.iter().map(|v| v.ln()).collect();
    let y: Vec<f64> = err.iter().map(|v| v.ln()).collect();
    let n = x.len() as f64;
    let mx = x.iter().sum::<f64>() / n;
    let my = y.iter().sum::<f64>() / n;
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    sxy / sxx
}

/// θ(t_end) of θ'' = accel(θ) from rest at θ₀, by classical RK4 in `steps` equal steps: the
/// reference angle of one-degree-of-freedom mechanisms (a pendulum, a sliding ladder).
pub fn rk4_angle_from_rest(
    theta0: f64,
    t_end: f64,
    steps: usize,
    accel: impl Fn(f64) -> f64,
) -> f64 {
    let h = t_end / steps as f64;
    let (mut th, mut w) = (theta0, 0.0);
    for _ in 0..steps {
        let (k1t, k1w) = (w, accel(th));
        let (k2t, k2w) = (w + 0.5 * h * k1w, accel(th + 0.5 * h * k1t));
        let (k3t, k3w) = (w + 0.5 * h * k2w, accel(th + 0.5 * h * k2t));
        let (k4t, k4w) = (w + h * k3w, accel(th + h * k3t));
        th += h / 6.0 * (k1t + 2.0 * k2t + 2.0 * k3t + k4t);
        w += h / 6.0 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w);
    }
    th
}

/// A fresh, empty scratch directory for one test.
pub fn scratch(name: &str) -> std::path::PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch directory");
    dir
}

/// The bundled study file `studies/<name>/<file>`.
pub fn study_path(name: &str, file: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("studies")
        .join(name)
        .join(file)
}

/// A mesh floor, 300 mm square at z = 0, cut into 3 × 3 squares of two triangles each,
/// wound to face +z (mm, OBJ).
pub fn floor_obj() -> String {
    let mut s = String::new();
    for j in 0..4 {
        for i in 0..4 {
            s += &format!("v {} {} 0\n", -150 + 100 * i, -150 + 100 * j);
        }
    }
    let v = |i: usize, j: usize| 1 + i + 4 * j;
    for j in 0..3 {
        for i in 0..3 {
            s += &format!("f {} {} {}\n", v(i, j), v(i + 1, j), v(i + 1, j + 1));
            s += &format!("f {} {} {}\n", v(i, j), v(i + 1, j + 1), v(i, j + 1));
        }
    }
    s
}

/// The rows of a results or part file, with the wall time (the one column that differs
/// between identical runs) zeroed.
pub fn stored_rows(path: &Path) -> Vec<mc_study::study::store::Row> {
    mc_study::study::store::read(path)
        .unwrap()
        .rows
        .into_iter()
        .map(|mut r| {
            r.diagnostics.wall_ms = 0.0;
            r
        })
        .collect()
}
