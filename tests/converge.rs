//! `mc-study converge` on the bouncing-ball study, whose first impact time is known in
//! closed form: the ladder's errors fall with the step size, the reference is the finest
//! run, and the recommendation is the cheapest rung under the target.

use mc_study::study::converge::{sweep, Fidelity, Ladder};
use mc_study::study::sample_run::Subject;
use mc_study::study::Study;
mod common;

use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

#[test]
fn step_size_ladder_converges_on_the_bouncing_ball() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/bouncing-ball/study.yaml");
    let study = Study::load(&path, None).unwrap();
    let Subject::Mechanism(scene) = &study.subject else {
        panic!("a mechanism")
    };
    let base = Fidelity::of(&scene.params);
    assert_eq!(base.h, 1e-4);
    let mut ladder = Ladder::around(&scene.params, 2);
    // the full ladder also varies the tolerances, θ, the scheme, and holds the presets
    let labels: Vec<String> = ladder.fidelities.iter().map(|f| f.label()).collect();
    assert_eq!(labels.len(), 16, "{labels:#?}");
    // around the combined scheme it also locates the impacts (the ball's moreau-jean
    // scheme has none to locate)
    let mut combined = scene.params.clone();
    combined.scheme = mc_study::integrator::Scheme::CombinedProjection;
    let around_combined: Vec<String> = Ladder::around(&combined, 2)
        .fidelities
        .iter()
        .map(|f| f.label())
        .collect();
    assert_eq!(around_combined.len(), 17, "{around_combined:#?}");
    let located: Vec<&String> = around_combined
        .iter()
        .filter(|l| l.ends_with(" impacts located"))
        .collect();
    assert_eq!(located.len(), 1, "{around_combined:#?}");
    assert!(
        located[0].starts_with("h=1e-4 combined-projection"),
        "{located:?}"
    );
    // a scene without a refinement window has no extrapolation rung
    let ball_scene = Ladder::around_scene(scene, 2);
    assert_eq!(ball_scene.fidelities.len(), 16);
    // the circuit breaker's plain window gets a rung with the extrapolation, and its
    // recommendation says what to change in the scene
    let c60 = Study::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/c60/study.yaml"),
        None,
    )
    .unwrap();
    let Subject::Mechanism(c60_scene) = &c60.subject else {
        panic!("a mechanism")
    };
    let c60_ladder = Ladder::around_scene(c60_scene, 3);
    let window: Vec<&Fidelity> = c60_ladder
        .fidelities
        .iter()
        .filter(|f| f.extrapolate.is_some())
        .collect();
    assert_eq!(window.len(), 1);
    assert_eq!(window[0].extrapolate, Some(true));
    assert!(window[0].label().ends_with(" window extrapolated"));
    assert!(window[0]
        .yaml()
        .ends_with("# and in the scene: refine: { …, extrapolate: true }\n"));
    assert_eq!(c60_ladder.reference.extrapolate, None);
    assert!(
        labels.iter().any(|l| l.starts_with("fast: h=4e-4")),
        "{labels:#?}"
    );
    assert!(
        labels.iter().any(|l| l.starts_with("accurate: h=2.5e-5")),
        "{labels:#?}"
    );
    assert!(labels.iter().any(|l| l.contains("θ=1 ")), "{labels:#?}");
    assert!(
        labels.iter().any(|l| l.contains("proj=1e-8")),
        "{labels:#?}"
    );
    let fast = ladder
        .fidelities
        .iter()
        .find(|f| f.preset.is_some())
        .unwrap();
    assert_eq!(fast.yaml(), "fidelity: { preset: fast }\n");
    // three adaptive rungs at 1e-3, 3e-4 and 1e-4 (the ball's study has no step control),
    // the largest step ten of the study's
    let adaptive: Vec<&Fidelity> = ladder
        .fidelities
        .iter()
        .filter(|f| f.step_control.is_some())
        .collect();
    let taus: Vec<f64> = adaptive
        .iter()
        .map(|f| f.step_control.as_ref().unwrap().tolerance)
        .collect();
    assert_eq!(taus, [1e-3, 3e-4, 1e-4]);
    assert!(adaptive
        .iter()
        .all(|f| f.step_control.as_ref().unwrap().h_max == 1e-3));
    assert!(adaptive[0].label().starts_with("τ=1e-3 adaptive"));
    assert!(adaptive[0]
        .yaml()
        .contains("step_control: { tolerance: 1e-3, h_max: 1e-3 s"));
    // the fixed rungs switch a controlled study's control off
    assert!(ladder.fidelities[0].yaml().contains("step_control: off"));
    let adaptive_rungs: Vec<Fidelity> = adaptive.into_iter().cloned().collect();
    // step sizes only, coarse to fine: 1e-3, 5e-4, 2e-4, 1e-4, 5e-5
    ladder.fidelities.truncate(5);
    let runs = AtomicUsize::new(0);
    let conv = sweep(&study, &ladder, None, |_, _, _| {
        runs.fetch_add(1, Ordering::Relaxed);
    })
    .unwrap();
    assert_eq!(
        runs.into_inner(),
        6 * 3,
        "5 rungs + the reference, 3 samples each"
    );
    // the runs go in parallel; their outputs do not depend on the thread count
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| sweep(&study, &ladder, None, |_, _, _| {}).unwrap());
    let bits = |c: &mc_study::study::converge::Convergence| -> Vec<u64> {
        c.runs
            .iter()
            .flatten()
            .flat_map(|r| r.outputs.iter().map(|x| x.to_bits()))
            .collect()
    };
    assert_eq!(bits(&one_thread), bits(&conv));
    assert_eq!(conv.sample_names, ["nominal", "sample 0", "sample 1"]);
    assert_eq!(conv.fidelities.last().unwrap().h, 1e-5);
    let k = conv
        .outputs
        .iter()
        .position(|(n, _)| n == "first_impact_time")
        .unwrap();
    // the reference impact time of the nominal drop (1 m centre, 0.1 m radius): the
    // closed form sqrt(2 · 0.9 / 9.81) within one reference step
    let t_ref = conv.runs.last().unwrap()[0].outputs[k];
    assert!((t_ref - (1.8f64 / 9.81).sqrt()).abs() <= 1e-5, "{t_ref}");
    // the impact is found within two steps (the activation forecast may close it a step
    // early or late), so the relative error is below 2h / t and falls with h (a wrong
    // reference or a mixed-up ladder would break either)
    let errors: Vec<f64> = (0..5).map(|f| conv.error(f, k)).collect();
    for (f, e) in errors.iter().enumerate() {
        let h = conv.fidelities[f].h;
        assert!(*e <= (2.0 * h + 1e-5) / 0.4, "h = {h}: relative error {e}");
    }
    assert!(errors[0] > 10.0 * errors[4], "{errors:?}");
    // the recommendation: the cheapest rung whose every output is within the target
    let target = 2e-3;
    let f = conv.recommend(target).expect("a rung meets 2e-3");
    for k in 0..conv.outputs.len() {
        assert!(conv.error(f, k) < target);
    }
    for g in 0..5 {
        if (0..conv.outputs.len()).all(|k| conv.error(g, k) < target) {
            assert!(conv.cost(f) <= conv.cost(g));
        }
    }
    assert!(conv.fidelities[f].yaml().contains("h: "));
    // the work–precision plot: one point per rung and output
    let fig = mc_study::report::work_precision(&conv, target);
    assert_eq!(fig.series.len(), conv.outputs.len());
    assert!(fig.series.iter().all(|(_, p)| p.len() == 5));
    let dir = std::env::temp_dir().join(format!("mc-study-converge-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let svg = mc_study::report::figures::save(&fig, &dir.join("wp")).unwrap();
    assert!(std::fs::metadata(&svg).unwrap().len() > 1000);
    assert!(std::fs::metadata(dir.join("wp.png")).unwrap().len() > 1000);
    // the CSV: a header and one line per run and output
    let csv = conv.csv();
    assert_eq!(csv.lines().count(), 1 + 6 * 3 * conv.outputs.len());
    assert!(csv
        .lines()
        .next()
        .unwrap()
        .ends_with(",wall_ms,steps,error"));
    // each run's steps: at a fixed step, the run's length over h (the same length at every
    // rung, within a step or two where it stops once its outputs are known)
    let length = |f: usize| conv.steps(f) as f64 * conv.fidelities[f].h;
    let reference = length(conv.fidelities.len() - 1);
    for f in 0..5 {
        let ratio = length(f) / reference;
        assert!((ratio - 1.0).abs() < 0.01, "rung {f}: {ratio}");
    }
    // with the adaptive rungs: their impact times are within 1e-8 relative of the
    // reference (the step shrinks at the impact), and they share the plot as triangles
    ladder.fidelities.extend(adaptive_rungs);
    let conv = sweep(&study, &ladder, None, |_, _, _| {}).unwrap();
    for f in 5..8 {
        assert!(
            conv.error(f, k) < 1e-8,
            "{}: {}",
            conv.fidelities[f].label(),
            conv.error(f, k)
        );
    }
    // (more accurate than the finest fixed rung, 5e-5 s: wall times, which the
    // recommendation weighs, are no test's business)
    for f in 5..8 {
        assert!(conv.error(f, k) < conv.error(4, k) / 10.0);
    }
    // and in at most half the steps of the study's own fixed step (1e-4 s, rung 3): the
    // steps grow in flight and shrink at the impacts only
    for f in 5..8 {
        assert!(
            2 * conv.steps(f) <= conv.steps(3),
            "{}: {} steps against {}",
            conv.fidelities[f].label(),
            conv.steps(f),
            conv.steps(3)
        );
    }
    let fig = mc_study::report::work_precision(&conv, target);
    assert!(fig
        .series
        .iter()
        .all(|(_, p)| p.iter().filter(|x| x.adaptive).count() == 3));
}

/// An output that grows as 1/h (the peak contact force of a rigid impact) gets converge's
/// verdict and is left out of the recommendation; the impact's impulse, which converges,
/// is not flagged.
#[test]
fn a_peak_impact_force_is_judged_step_dependent() {
    let dir = common::scratch("converge-peak");
    let ball = Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/bouncing-ball/scene.yaml");
    let scene = std::fs::read_to_string(ball).unwrap()
        + "  - { name: peak_force, measure: { contact_force: floor }, reduce: max, to: second_impact_time }\n"
        + "  - { name: impact, measure: { impulse: floor }, reduce: max, to: second_impact_time }\n";
    std::fs::write(dir.join("scene.yaml"), scene).unwrap();
    std::fs::write(
        dir.join("study.yaml"),
        "scene: scene.yaml\nsamples: 1\nparameters:\n  - { path: contacts.floor.e, distribution: { fixed: 0.9 } }\noutputs: [first_impact_time, peak_force, impact]\n",
    )
    .unwrap();
    let study = Study::load(&dir.join("study.yaml"), None).unwrap();
    let Subject::Mechanism(scene) = &study.subject else {
        panic!("a mechanism")
    };
    assert!(
        scene.probes[3].caution.is_some(),
        "the peak is cautioned at load"
    );
    let mut ladder = Ladder::around(&scene.params, 0);
    ladder.fidelities.truncate(5);
    let conv = sweep(&study, &ladder, None, |_, _, _| {}).unwrap();
    let drifting: Vec<&str> = conv
        .step_dependent(1e-2)
        .iter()
        .map(|d| conv.outputs[d.output].0.as_str())
        .collect();
    assert_eq!(
        drifting,
        ["peak_force"],
        "{drifting:?} {}",
        conv.describe(1e-2)
    );
    let text = conv.describe(1e-2);
    assert!(
        text.contains("(!) peak_force: does not converge with h"),
        "{text}"
    );
    // the recommendation judges the converging outputs only
    assert!(conv.recommend(1e-2).is_some());
}

/// `converge --out` writes only into a new or empty directory, or one of its own: a
/// directory holding anything else is refused before any run.
#[test]
fn converge_refuses_a_foreign_output_directory() {
    let dir = common::scratch("converge-out");
    std::fs::write(dir.join("notes.txt"), "mine").unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_mc-study"))
        .args(["converge", "--out"])
        .arg(&dir)
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/bouncing-ball/study.yaml"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(
        e.contains("holds other files") && e.contains("notes.txt"),
        "{e}"
    );
    assert_eq!(
        std::fs::read_to_string(dir.join("notes.txt")).unwrap(),
        "mine"
    );
    assert!(!dir.join("converge.csv").exists());
}

/// The bouncing ball with a flagged output (the peak force of its impact) and one that is
/// constant in the study (the first impact time does not depend on the restitution it
/// samples), with σ from the study's results: the constant output's errors are relative
/// to its value (its σ of round-off would make them 1e12 σ) and it stays out of the plot,
/// the flagged one is left out of the recommendation, and both are named.
#[test]
fn converge_names_its_constant_and_flagged_outputs_and_still_recommends() {
    let dir = common::scratch("converge-constant-flagged");
    let ball = Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/bouncing-ball/scene.yaml");
    let scene = std::fs::read_to_string(ball).unwrap()
        + "  - { name: peak_force, measure: { contact_force: floor }, reduce: max, to: second_impact_time }\n";
    std::fs::write(dir.join("scene.yaml"), scene).unwrap();
    std::fs::write(
        dir.join("study.yaml"),
        "scene: scene.yaml\nsamples: 8\nparameters:\n  - { path: contacts.floor.e, distribution: { uniform: { lower: 0.8, upper: 0.95 } } }\noutputs: [apex_after_first_bounce, peak_force, first_impact_time]\nfidelity: { h: 1 ms }\n",
    )
    .unwrap();
    let study = Study::load(&dir.join("study.yaml"), None).unwrap();
    let mut options = mc_study::study::runner::RunOptions::new(dir.join("out"));
    options.progress = false;
    mc_study::study::runner::run(&study, &options).unwrap();
    let merged = mc_study::study::merge::merge(&dir.join("out"), false).unwrap();
    let names: Vec<String> = study.outputs.iter().map(|o| o.name.clone()).collect();
    let sigma = mc_study::study::converge::sigma_of(&merged.summary, &names).unwrap();
    assert!(
        sigma[0] > 0.0 && sigma[1] > 0.0 && sigma[2].is_nan(),
        "{sigma:?}"
    );
    let Subject::Mechanism(scene) = &study.subject else {
        panic!("a mechanism")
    };
    let mut ladder = Ladder::around(&scene.params, 1);
    ladder.fidelities.truncate(5);
    let conv = sweep(&study, &ladder, Some(sigma), |_, _, _| {}).unwrap();
    assert!(conv.constant(2) && !conv.constant(0) && !conv.constant(1));
    // relative to 0.43 s: within two steps of h ≤ 10 ms
    for f in 0..5 {
        let h = conv.fidelities[f].h;
        assert!(conv.error(f, 2) < 2.0 * h / 0.4, "{}", conv.describe(0.1));
    }
    let left_out: Vec<usize> = conv.left_out(0.1).iter().map(|(k, _)| *k).collect();
    assert_eq!(left_out, [1]);
    let f = conv.recommend(0.1).expect("a rung meets 0.1 σ on the apex");
    assert!(conv.error(f, 0) < 0.1 && conv.error(f, 1) > 0.1);
    let text = conv.describe(0.1);
    assert!(
        text.contains("first_impact_time: constant to round-off"),
        "{text}"
    );
    assert!(
        text.contains("(!) peak_force: does not converge with h"),
        "{text}"
    );
    let plot = mc_study::report::work_precision(&conv, 0.1);
    let plotted: Vec<&str> = plot.series.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(plotted, ["apex_after_first_bounce", "peak_force"]);
}

/// A sweep built by hand: h = 4, 2, 1 ms and a reference. Output 0 changes by 1e-4 between
/// the coarse rungs and by 5e-4 between the fine ones: a drift by ratio, but a drift only
/// where that change is large against σ. A failed run shows as inf with its reason.
#[test]
fn a_drift_must_be_large_against_sigma_and_failures_say_why() {
    use mc_study::integrator::IntegrationParameters;
    use mc_study::study::converge::{Convergence, LeftOut, Run};
    let base = Fidelity::of(&IntegrationParameters::default());
    let fid = |h: f64| Fidelity { h, ..base.clone() };
    let run = |y: f64| Run {
        outputs: vec![y],
        steps: 10,
        wall_ms: 1.0,
        error: None,
    };
    let conv = |sigma: f64, failed: bool| Convergence {
        cautions: vec![None],
        outputs: vec![("force".into(), "N".into())],
        fidelities: vec![fid(4e-3), fid(2e-3), fid(1e-3), fid(5e-4)],
        sample_names: vec!["nominal".into(), "sample 0".into()],
        runs: vec![
            vec![run(1.0), run(1.0)],
            vec![run(1.0001), run(1.0001)],
            if failed {
                vec![
                    run(1.0001),
                    Run {
                        outputs: vec![f64::NAN],
                        steps: 3,
                        wall_ms: 1.0,
                        error: Some("steps did not converge (3 of 40)\ndetail".into()),
                    },
                ]
            } else {
                vec![run(1.0001), run(1.0001)]
            },
            vec![run(1.0006), run(1.0006)],
        ],
        sigma: Some(vec![sigma]),
    };
    assert!(conv(1.0, false).step_dependent(0.01).is_empty());
    assert_eq!(conv(0.01, false).step_dependent(0.01).len(), 1);
    // a flagged output is left out even where it does not drift
    let mut flagged = conv(1.0, false);
    for (f, y) in [1.0, 1.0004, 1.0005, 1.0006].into_iter().enumerate() {
        flagged.runs[f] = vec![run(y), run(y)];
    }
    assert!(flagged.step_dependent(1e-5).is_empty());
    assert!(flagged.recommend(1e-5).is_none());
    flagged.cautions[0] = Some("a peak of an impulsive force".into());
    assert_eq!(flagged.left_out(0.01), [(0, LeftOut::Flagged)]);
    assert!(flagged.recommend(1e-5).is_some());
    assert!(flagged
        .describe(0.01)
        .contains("(!) force: left out of the recommendation: flagged at load time"));
    let c = conv(1.0, true);
    assert!(c.error(2, 0).is_infinite());
    let text = c.describe(0.01);
    assert!(
        text.contains("failed ×1 (shown as inf; first at h=1e-3")
            && text.contains("sample 0): steps did not converge (3 of 40)"),
        "{text}"
    );
}
