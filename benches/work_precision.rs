//! Work–precision curves: error against wall time per run for the bouncing ball, the free
//! rigid body and the circuit breaker under each scheme, over a ladder of step sizes,
//! against a reference at a tenth of the finest step (combined projection). Prints the
//! table and writes `target/work-precision/<scene>.csv` and `.svg`/`.png` (the figure of
//! `mc-study converge`). Run: `cargo bench --bench work_precision` (about 2 minutes;
//! `-- ball` or `-- body` for one scene). Times are medians of 3 runs on one core.

use mc_study::integrator::Scheme;
use mc_study::report::figures::{save, WorkPoint, WorkPrecisionFigure};
use mc_study::scene::Scene;
use mc_study::study::sample_run::Subject;
use std::path::Path;
use std::time::Instant;

const SCHEMES: [Scheme; 3] = [
    Scheme::MoreauJean,
    Scheme::CombinedProjection,
    Scheme::DirectProjection,
];

fn scene(name: &str) -> Scene {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("studies")
        .join(name);
    Scene::load(&dir.join("scene.yaml")).unwrap()
}

/// The scene's probes (names and values), or for a scene without probes the attitude
/// quaternion at the end of its run; the error if the run failed.
fn outputs(s: &Scene) -> Result<(Vec<String>, Vec<f64>), String> {
    if s.probes.is_empty() {
        let mut sim = s.simulation().unwrap();
        sim.run_until(s.duration, |_, _| {})
            .map_err(|e| e.to_string())?;
        let q = sim.state.poses[0].p;
        // the sign of a quaternion is arbitrary: compare q with w ≥ 0
        let k = if q.w < 0.0 { -1.0 } else { 1.0 };
        let names = ["q.w", "q.x", "q.y", "q.z"].map(String::from).to_vec();
        return Ok((names, vec![k * q.w, k * q.i, k * q.j, k * q.k]));
    }
    let subject = Subject::Mechanism(Box::new(s.clone()));
    let all: Vec<usize> = (0..s.probes.len()).collect();
    let o = subject.run(&[], &all);
    match o.error {
        Some(e) => Err(e),
        None => Ok((s.probes.iter().map(|p| p.name.clone()).collect(), o.outputs)),
    }
}

fn main() {
    let filter = std::env::args()
        .skip(1)
        .find(|a| !a.starts_with('-'))
        .unwrap_or_default();
    // (scene, step ladder, duration override)
    let cases: Vec<(&str, Vec<f64>, Option<f64>)> = vec![
        ("bouncing-ball", vec![4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4], None),
        (
            "free-body",
            vec![4e-2, 2e-2, 1e-2, 5e-3, 2.5e-3],
            Some(10.0),
        ),
        ("c60", vec![4e-5, 2e-5, 1e-5, 5e-6], None),
    ];
    let out = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/work-precision");
    std::fs::create_dir_all(&out).unwrap();
    for (name, hs, duration) in cases {
        if !name.contains(&filter) {
            continue;
        }
        let mut base = scene(name);
        if let Some(d) = duration {
            base.duration = d;
        }
        let finest = hs.iter().copied().fold(f64::INFINITY, f64::min);
        let mut reference = base.clone();
        reference.params.h = finest / 10.0;
        reference.params.scheme = Scheme::CombinedProjection;
        reference.params.solver.tolerance = reference.params.solver.tolerance.min(1e-10);
        let (names, y0) = outputs(&reference).expect("the reference run");
        let scale: Vec<f64> = y0.iter().map(|v| v.abs().max(1e-300)).collect();
        println!(
            "\n{name}: largest relative output error against h = {:e} (combined projection)",
            reference.params.h
        );
        println!("| scheme | h (s) | ms per run | largest relative error | of output |");
        println!("|---|---|---|---|---|");
        let mut csv = String::from("scheme,h,ms,error,output\n");
        let mut series = Vec::new();
        for scheme in SCHEMES {
            let mut pts = Vec::new();
            for &h in &hs {
                let mut s = base.clone();
                s.params.h = h;
                s.params.scheme = scheme;
                let mut times = Vec::new();
                let mut y = Ok(Default::default());
                for _ in 0..3 {
                    let t = Instant::now();
                    y = outputs(&s);
                    times.push(t.elapsed().as_secs_f64() * 1e3);
                }
                times.sort_by(f64::total_cmp);
                let ms = times[1];
                let y = match y {
                    Ok((_, y)) => y,
                    Err(e) => {
                        println!("| {} | {h:e} | {ms:.2} | failed: {e} | |", scheme.name());
                        csv += &format!("{},{h:e},{ms:.4},inf,failed\n", scheme.name());
                        continue;
                    }
                };
                let (worst, err) = y
                    .iter()
                    .zip(&y0)
                    .zip(&scale)
                    .map(|((a, b), s)| (a - b).abs() / s)
                    .enumerate()
                    .fold((0, 0.0), |m, (k, e)| if e > m.1 { (k, e) } else { m });
                println!(
                    "| {} | {h:e} | {ms:.2} | {err:.2e} | {} |",
                    scheme.name(),
                    names[worst]
                );
                csv += &format!("{},{h:e},{ms:.4},{err:e},{}\n", scheme.name(), names[worst]);
                pts.push(WorkPoint {
                    cost: ms,
                    error: err,
                    adaptive: false,
                });
            }
            series.push((scheme.name().to_string(), pts));
        }
        std::fs::write(out.join(format!("{name}.csv")), csv).unwrap();
        let fig = WorkPrecisionFigure {
            title: format!("{name}: work–precision per scheme"),
            y_desc: "largest relative error".into(),
            series,
            target: 1e-3,
        };
        save(&fig, &out.join(name)).unwrap();
    }
}
