//! Richardson extrapolation over the refinement window (`refine: { extrapolate: true }`),
//! on the frictionless clearance pendulum (a 1 m bar released horizontal, hanging from a
//! 0.07 mm clearance joint, its journal sliding around the bore's wall): the fork
//! reproduces the two plain runs exactly, and neither the plain runs nor the extrapolated
//! ones keep the first-order error that a contact law on start-of-step rows leaves there.

use mc_study::probe::run::run_probes;
use mc_study::scene::Scene;
use mc_study::study::sample_run::Subject;

/// The pendulum with its refinement window from the first contact of the pivot, at step
/// `window`; probes: the times the bar's free end first passes below the pivot, going
/// down and coming back.
fn pendulum(window: &str, extrapolate: bool) -> String {
    let crossing = |direction: &str| {
        format!(
            "{{ crosses: 0, measure: {{ distance: {{ from: {{ body: ground, point: [0, 0, 0] }}, to: {{ body: bar, point: [0.5 m, 0, 0] }}, axis: [1, 0, 0] }} }}, direction: {direction} }}"
        )
    };
    format!(
        "
name: pendulum-clearance-extrapolated
duration: 1.6 s
gravity: [0, 0, -9.81]
integrator: {{ h: 0.1 ms, scheme: combined-projection, locate_impacts: true }}
refine: {{ after: pivot, for: 2 s, h: {window}, extrapolate: {extrapolate} }}
bodies:
  - name: bar
    mass: 1 kg
    shape: {{ box: {{ size: [1 m, 20 mm, 20 mm] }} }}
    position: [0.5 m, 0, 0]
joints:
  - {{ name: pivot, type: revolute-clearance, body_a: ground, body_b: bar, anchor: [0, 0, 0],
      axis: [0, 1, 0], clearance: 0.07 mm, journal_radius: 5 mm, bore_length: 10 mm,
      axial_play: 0.1 mm, mu: 0, e: 0 }}
probes:
  - {{ name: down, event: {} }}
  - {{ name: back, event: {} }}
",
        crossing("down"),
        crossing("up")
    )
}

/// The two probes and the steps taken.
fn run(text: &str) -> ([f64; 2], u64) {
    let subject = Subject::from_yaml(text, "pendulum").unwrap_or_else(|e| panic!("{e}"));
    let o = subject.run(&[], &[0, 1]);
    assert_eq!(o.error, None);
    ([o.outputs[0], o.outputs[1]], o.diagnostics.steps)
}

/// The window opens where the falling journal first meets its bore, √(2c/g) = 3.78 ms
/// after the release (the bar falls without turning until then), and the run forks there:
/// every probe is then 2 f(h/2) − f(h) of the two plain runs to the last bit, and the
/// steps are those of both runs with the shared ones counted once.
#[test]
fn the_fork_reproduces_the_two_plain_runs_exactly() {
    let (extrapolated, steps) = run(&pendulum("0.2 ms", true));
    let (fine, fine_steps) = run(&pendulum("0.1 ms", false));
    let (coarse, coarse_steps) = run(&pendulum("0.2 ms", false));
    for k in 0..2 {
        assert_eq!(extrapolated[k], 2.0 * fine[k] - coarse[k], "probe {k}");
    }
    let scene = Scene::from_yaml(&pendulum("0.2 ms", true), "pendulum").unwrap();
    let sim = scene.simulation().unwrap();
    let fork = run_probes(
        sim,
        &scene.probes,
        &scene.curves,
        scene.duration,
        true,
        |_, _, _| {},
    );
    let at = fork.forked_at.expect("the window opened");
    let fall = (2.0 * 0.07e-3 / 9.81f64).sqrt();
    assert!(
        at >= fall && at < fall + 0.1e-3,
        "forked at {at} s, contact at {fall} s"
    );
    let shared = (at / 0.1e-3).round() as u64;
    assert_eq!(steps, fine_steps + coarse_steps - shared);
    assert_eq!(fork.stats.steps, steps);
}

/// The sliding journal's contact acts on its mid-step rows and meets its velocity
/// condition on its end rows, so the swing carries no first-order error: at windows of 0.2
/// and 0.1 ms the crossing times are within 1e-7 s of the reference, plain or
/// extrapolated, where on start-of-step rows the plain ones were 4.5e-6 and 2.2e-6 s off
/// going down and 7.6e-5 and 3.8e-5 s coming back (first order, which the extrapolation
/// then removed). Measured: 4e-9–7e-8 s plain and 2e-8–5e-8 s extrapolated, the floor
/// set by the located impacts and the solver. Reference: plain at 12.5 µs.
#[test]
fn the_window_carries_no_first_order_error_plain_or_extrapolated() {
    let reference = run(&pendulum("12.5 us", false)).0;
    for window in ["0.2 ms", "0.1 ms"] {
        for extrapolate in [false, true] {
            let (p, _) = run(&pendulum(window, extrapolate));
            for k in 0..2 {
                let error = (p[k] - reference[k]).abs();
                assert!(
                    error < 1e-7,
                    "probe {k} at {window}, extrapolated {extrapolate}: {error:.2e} s off"
                );
            }
        }
    }
}
