//! The refinement window (`refine:`): the step it takes, where it opens and closes (after
//! its duration, or at its closing event), and that it scales with h, on the bouncing ball.

mod common;

use mc_study::scene::Scene;

/// The e = 0.9 ball from 0.9 m (first impact at t₁ = √(2 · 0.9 / g) = 0.4284 s) at h = 1 ms,
/// with `refine`, run at step `h` (as a study's fidelity would set it).
fn ball(refine: &str, h: f64) -> mc_study::integrator::Simulation {
    let mut scene = ball_scene(refine, "");
    scene.params.h = h;
    common::simulation(scene)
}

/// The ball's scene with `refine` and the `probes` block given.
fn ball_scene(refine: &str, probes: &str) -> Scene {
    let yaml = format!(
        "
duration: 1.3 s
gravity: [0, 0, -9.81]
integrator: {{ h: 1 ms, scheme: moreau-jean }}
{refine}
bodies:
  - name: ball
    mass: 1 kg
    shape: {{ sphere: {{ radius: 0.1 m }} }}
    position: [0, 0, 1 m]
contacts:
  - name: floor
    body: ball
    shape: {{ sphere: {{ radius: 0.1 m }} }}
    against: ground
    against_shape: {{ plane: {{ point: [0, 0, 0], normal: [0, 0, 1] }} }}
    mu: 0
    e: 0.9
{probes}"
    );
    Scene::from_yaml(&yaml, "refine").unwrap_or_else(|e| panic!("{e}"))
}

/// Every step's (start, size) up to 1.3 s (the second impact is at 1.199 s).
fn steps(sim: &mut mc_study::integrator::Simulation) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let mut t = sim.state.t;
    sim.run_until(1.3, |s, _| {
        out.push((t, s.state.t - t));
        t = s.state.t;
    })
    .unwrap();
    out
}

/// Every step of `steps` is h/10 from `from` to `to` (the window) and h elsewhere.
fn assert_window(steps: &[(f64, f64)], h: f64, from: f64, to: f64) {
    for &(t, d) in steps {
        let expected = if t >= from - 1e-9 && t < to - 1e-9 {
            h / 10.0
        } else {
            h
        };
        assert!(
            (d - expected).abs() < 1e-9 * h,
            "step at t = {t}: {d}, expected {expected} (window {from} to {to})"
        );
    }
}

/// The steps are h until the step in which the floor first carries an impulse (the one
/// that ends at t₁ rounded up to the ms), h/10 for the next 50 ms, the last of them ending
/// exactly at the window's end, then h again, also at the second impact (the window opens
/// once); without `refine` every step is h.
#[test]
fn the_window_opens_at_the_first_closing_and_takes_its_own_step() {
    let h = 1e-3;
    let plain = steps(&mut ball("", h));
    assert!(plain.iter().all(|&(_, d)| (d - h).abs() < 1e-12));
    let impact_end = 1e-3 * (0.4284f64 * 1e3).ceil();
    let mut sim = ball("refine: { after: floor, for: 50 ms, h: 0.1 ms }", h);
    let refined = steps(&mut sim);
    let window_end = impact_end + 0.05;
    assert_window(&refined, h, impact_end, window_end);
    assert!(
        refined
            .iter()
            .any(|&(t, d)| (t + d - window_end).abs() < 1e-12),
        "a step ends at the window's end {window_end}"
    );
    assert_eq!(refined.len(), plain.len() + 450);
    // the window's step is a ratio of h: a fidelity of h = 0.5 ms makes it 0.05 ms
    let mut half = ball("refine: { after: floor, for: 50 ms, h: 0.1 ms }", 0.5e-3);
    let half_steps = steps(&mut half);
    let finest = half_steps.iter().map(|&(_, d)| d).fold(f64::MAX, f64::min);
    assert!((finest - 0.05e-3).abs() < 1e-12, "{finest}");
}

/// With `until`, the window closes at the end of the step in which its event probe first
/// happens: the ball's centre rising through 0.5 m after the first bounce, at
/// t₁ + (v − √(v² − 2 g · 0.4 m))/g = 0.5549 s (v = 0.9 √(2 g · 0.9 m) = 3.782 m/s). The
/// steps are h/10 from the impact's step to that step, h after it (the window does not
/// open again at the second impact), although `for` would have kept the window open for
/// 0.5 s; an event that comes after `for` is over leaves the window's duration as it is.
#[test]
fn a_window_with_until_closes_at_its_event() {
    let h = 1e-3;
    let g = 9.81f64;
    let t1 = (2.0 * 0.9 / g).sqrt();
    let v = 0.9 * (2.0 * g * 0.9f64).sqrt();
    let rise = (v - (v * v - 2.0 * g * 0.4).sqrt()) / g;
    let event = t1 + rise;
    assert!((event - 0.5549).abs() < 1e-4, "{event}");
    let probes = "probes:
  - name: rebound
    event: { crosses: 0.5 m, measure: { distance: { from: { body: ground, point: [0, 0, 0] }, to: { body: ball, point: [0, 0, 0] }, axis: [0, 0, 1] } }, direction: up }
";
    let run_steps = |refine: &str| {
        let scene = ball_scene(refine, probes);
        let sim = common::simulation(scene.clone());
        let mut out = Vec::new();
        let mut t = sim.state.t;
        let run = mc_study::probe::run::run_probes(
            sim,
            &scene.probes,
            &scene.curves,
            1.3,
            false,
            |s, _, _| {
                out.push((t, s.state.t - t));
                t = s.state.t;
            },
        );
        (out, run.values[0].clone().unwrap())
    };
    let (steps, at) = run_steps("refine: { after: floor, for: 500 ms, h: 0.1 ms, until: rebound }");
    // within the impact's step h (the impact is not located: the bounce starts up to h late)
    assert!(
        (at - event).abs() < h,
        "the event at {at}, expected {event}"
    );
    let impact_end = 1e-3 * (t1 * 1e3).ceil();
    // the window's steps are h/10 from the impact's step on: its last one ends in the
    // 0.1 ms that holds the event, and every later step is h
    let window_end = impact_end + 1e-4 * ((at - impact_end) / 1e-4).ceil();
    // (the last step ends at the run's end, off the grid that the window shifted)
    let (last, taken) = steps.split_last().unwrap();
    assert!((last.0 + last.1 - 1.3).abs() < 1e-12 && last.1 <= h);
    assert_window(taken, h, impact_end, window_end);
    let fine = steps.iter().filter(|&&(_, d)| d < 0.5 * h).count();
    let expected_fine = ((window_end - impact_end) / 1e-4).round() as usize;
    assert_eq!(fine, expected_fine);
    assert!(fine > 1000 && fine < 1300, "{fine}");
    // an event after `for` is over: the window lasts its 50 ms, as without `until`
    let (late, _) = run_steps("refine: { after: floor, for: 50 ms, h: 0.1 ms, until: rebound }");
    let fine = late.iter().filter(|&&(_, d)| d < 0.5 * h).count();
    assert_eq!(fine, 500);
    // `simulate` reports where the window opened and closed, and its step
    let options = mc_study::single_run::SimulateOptions {
        duration: None,
        trajectory: None,
        drawing: None,
    };
    let scene = ball_scene(
        "refine: { after: floor, for: 500 ms, h: 0.1 ms, until: rebound }",
        probes,
    );
    let report = mc_study::single_run::simulate(&scene, "ball", &options).unwrap();
    let (from, to, step) = report.window.expect("the window opened");
    assert!((from - impact_end).abs() < 1e-12 && (to - window_end).abs() < 1e-9);
    assert!((step - 1e-4).abs() < 1e-15);
    assert!(report.to_string().contains(&format!(
        "window           h = 1e-4 s from t = {impact_end:.6} s to {window_end:.6} s"
    )));
}

/// With `approach`, the steps before the window opens are the approach's: 5 ms up to the
/// end of the step in which the floor first carries an impulse (within two approach steps
/// of the impact at t₁, which the forecast activates a step late or not), then the
/// window's 0.1 ms for 50 ms, then h. The approach's step is a ratio of h too: at
/// h = 0.5 ms it is 2.5 ms.
#[test]
fn the_approach_takes_its_own_step_until_the_window_opens() {
    let refine = "refine: { after: floor, for: 50 ms, h: 0.1 ms, approach: 5 ms }";
    let t1 = (2.0 * 0.9 / 9.81f64).sqrt();
    for h in [1e-3, 0.5e-3] {
        let approach = 5.0 * h;
        let taken = steps(&mut ball(refine, h));
        let opened = taken
            .iter()
            .find(|&&(_, d)| d < 0.5 * approach)
            .map(|&(t, _)| t)
            .expect("the window opens");
        assert!(
            opened > t1 && opened < t1 + 2.0 * approach,
            "h = {h}: the window opened at {opened}, the impact is at {t1}"
        );
        let window_end = opened + 0.05;
        for &(t, d) in &taken {
            let expected = if t < opened - 1e-9 {
                approach
            } else if t < window_end - 1e-9 {
                0.1 * h
            } else {
                h
            };
            assert!(
                (d - expected).abs() < 1e-9 * h,
                "h = {h}: step at t = {t}: {d}, expected {expected} (window {opened} to {window_end})"
            );
        }
        let coarse = taken.iter().filter(|&&(t, _)| t < opened - 1e-9).count();
        assert_eq!(coarse, (opened / approach).round() as usize);
    }
}
