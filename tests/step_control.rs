//! Error-controlled step size (`step_control`): the error it leaves against closed forms
//! and fine fixed-step runs, where it puts its steps, and that it changes nothing when off.

mod common;

use mc_study::integrator::Simulation;
use mc_study::scene::Scene;

const G: f64 = 9.81;

fn scene(yaml: &str) -> Simulation {
    common::simulation(Scene::from_yaml(yaml, "step-control").unwrap_or_else(|e| panic!("{e}")))
}

/// Runs to `t_end`, returning every accepted step as (end time, size).
fn steps(sim: &mut Simulation, t_end: f64) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    sim.run_until(t_end, |s, _| out.push((s.state.t, s.h())))
        .unwrap();
    out
}

/// A 1 kg box thrown at (3, 0, 4) m/s, spinning at 2 rad/s about its long axis, under
/// gravity: the θ = 1/2 step is exact on a constant acceleration, so the estimate finds no
/// error, and the step doubles from its first size to h_max and stays there.
#[test]
fn a_ballistic_arc_grows_its_step_to_the_largest_and_keeps_the_closed_form() {
    let yaml = r#"
duration: 1 s
gravity: [0, 0, -9.81]
integrator: { h: 1 ms, step_control: { tolerance: 1e-6, h_max: 50 ms } }
bodies:
  - name: box
    mass: 1 kg
    shape: { box: { size: [0.3, 0.1, 0.1] } }
    velocity: [3, 0, 4]
    angular_velocity: [2, 0, 0]
"#;
    let mut sim = scene(yaml);
    let s = steps(&mut sim, 0.8);
    let sizes: Vec<f64> = s.iter().map(|x| x.1).collect();
    // the first step, which no estimate judges, then 1, 2, 4, 8, 16, 32 ms, then 50 ms to
    // the end (the last one cut to end at 0.8 s)
    assert_eq!(&sizes[..7], &[1e-3, 1e-3, 2e-3, 4e-3, 8e-3, 16e-3, 32e-3]);
    assert!(sizes[7..sizes.len() - 1]
        .iter()
        .all(|&h| (h - 0.05).abs() < 1e-12));
    assert!(s.len() <= 7 + 15 + 1, "{} steps", s.len());
    assert_eq!(sim.stats.rejected_steps, 0);
    let t = sim.state.t;
    let x = sim.state.poses[0].x;
    let exact = (3.0 * t, 0.0, 4.0 * t - 0.5 * G * t * t);
    let err = ((x.x - exact.0).powi(2) + x.y.powi(2) + (x.z - exact.2).powi(2)).sqrt();
    assert!(err < 1e-12, "{err:e}");
    let spin = sim.state.v[3];
    assert!((spin - 2.0).abs() < 1e-12, "{spin}");
}

/// The bar pendulum of studies/pendulum (1 m, pivoting at one end) from horizontal: its
/// angle against a fixed-step run at 2 µs, whose own error is below 1e-9 rad.
fn pendulum(h: &str, control: &str) -> Simulation {
    let yaml = format!(
        r#"
duration: 2 s
gravity: [0, 0, -9.81]
integrator: {{ h: {h}, scheme: combined-projection {control} }}
bodies:
  - name: bar
    mass: 1 kg
    shape: {{ box: {{ size: [1 m, 20 mm, 20 mm] }} }}
    position: [0.5 m, 0, 0]
joints:
  - name: pivot
    type: revolute
    body_a: ground
    body_b: bar
    anchor: [0, 0, 0]
    axis: [0, 1, 0]
"#
    );
    scene(&yaml)
}

fn angle(sim: &Simulation) -> f64 {
    let x = sim.state.poses[0].x;
    x.z.atan2(x.x)
}

#[test]
fn a_smooth_pendulum_keeps_its_error_within_a_stated_multiple_of_the_tolerance() {
    let t_end = 1.5;
    let mut reference = pendulum("2 us", "");
    reference.run_until(t_end, |_, _| {}).unwrap();
    let a0 = angle(&reference);
    let mut errors = Vec::new();
    let mut counts = Vec::new();
    for tau in [1e-4, 1e-5, 1e-6] {
        let mut sim = pendulum(
            "1 ms",
            &format!(
                ", step_control: {{ tolerance: {tau}, h_max: 20 ms, length: 1 m, speed: 1 m/s }}"
            ),
        );
        let s = steps(&mut sim, t_end);
        let err = (angle(&sim) - a0).abs();
        eprintln!(
            "τ = {tau:e}: error {err:.3e} rad, {} steps, {} rejected, h in [{:.2e}, {:.2e}]",
            s.len(),
            sim.stats.rejected_steps,
            s.iter().map(|x| x.1).fold(f64::MAX, f64::min),
            s.iter().map(|x| x.1).fold(0.0, f64::max)
        );
        errors.push(err);
        counts.push(s.len());
    }
    // measured: 0.099 τ rad at each τ (the joint's reaction makes the velocity step of
    // first order, and the control holds its local error h²/2 · a' to τ)
    for (tau, err) in [1e-4, 1e-5, 1e-6].iter().zip(&errors) {
        assert!(
            *err < 0.2 * tau,
            "τ = {tau:e}: error {err:e} rad, C = 0.2 rad"
        );
    }
    assert!(errors[2] < errors[0] / 50.0, "{errors:?}");
    // the step of a first-order control goes as √τ
    let ratio = counts[2] as f64 / counts[0] as f64;
    assert!((5.0..20.0).contains(&ratio), "{counts:?}");
}

/// The bundled ball (radius 0.1 m, centre at 1 m) with e = 0.8 under plain Moreau–Jean,
/// whose impacts are not located: the control shrinks the step at each impact until the
/// misplacement h/2 · Δv is within τ · length.
#[test]
fn a_bouncing_ball_meets_its_impacts_and_apexes_with_small_steps_only_near_impacts() {
    let yaml = r#"
duration: 3 s
gravity: [0, 0, -9.81]
integrator: { h: 1 ms, scheme: moreau-jean, step_control: { tolerance: 1e-6, h_max: 20 ms, length: 1 m } }
bodies:
  - name: ball
    mass: 1 kg
    shape: { sphere: { radius: 0.1 m } }
    position: [0, 0, 1 m]
contacts:
  - name: floor
    body: ball
    shape: { sphere: { radius: 0.1 m } }
    against_shape: { plane: { point: [0, 0, 0], normal: [0, 0, 1] } }
    e: 0.8
"#;
    let (e, g0): (f64, f64) = (0.8, 0.9);
    let t1 = (2.0 * g0 / G).sqrt();
    let impacts: Vec<f64> = (0..4)
        .scan(t1, |t, k| {
            let now = *t;
            *t += 2.0 * e.powi(k + 1) * t1;
            Some(now)
        })
        .collect();
    let mut sim = scene(yaml);
    let mut seen = Vec::new();
    let mut apexes = Vec::new();
    let mut small = Vec::new();
    let mut vz_before = 0.0;
    sim.run_until(impacts[3] + 0.1, |s, _| {
        let vz = s.state.v[2];
        if vz_before < 0.0 && vz > 0.0 {
            seen.push((s.state.t, s.h()));
            // the flight's invariant: the apex the ball now rises to
            apexes.push(s.state.poses[0].x.z - 0.1 + vz * vz / (2.0 * G));
        }
        if s.h() < 5e-3 {
            small.push(s.state.t);
        }
        vz_before = vz;
    })
    .unwrap();
    assert_eq!(seen.len(), 4, "{seen:?}");
    for (k, ((t, h), exact)) in seen.iter().zip(&impacts).enumerate() {
        // the impact lies within its step, which the control made small
        assert!(*h < 1e-6, "impact {k}: step {h:e}");
        assert!(
            (t - exact).abs() < 2e-6,
            "impact {k}: at {t}, closed form {exact}"
        );
        let apex = g0 * e.powi(2 * (k as i32 + 1));
        let err = (apexes[k] - apex).abs();
        assert!(
            err < 2e-5,
            "apex {k}: {} m, closed form {apex} m",
            apexes[k]
        );
    }
    // every step under h_max / 4 falls within 0.15 s of an impact, or of the start (the
    // first step is 1 ms)
    for t in &small {
        let near = impacts
            .iter()
            .chain(&[0.0])
            .map(|i| (t - i).abs())
            .fold(f64::MAX, f64::min);
        assert!(
            near < 0.15,
            "a small step at {t} s, {near} s from an impact"
        );
    }
    assert!(
        sim.stats.max_penetration < 1e-5,
        "{:e}",
        sim.stats.max_penetration
    );
}

/// A block sliding down a 20° incline at 2 m/s with μ = 0.5 stops at t* = v₀ / (g (μ cos β
/// − sin β)) = 1.59493 s; the step grows while it slides and shrinks at the stop.
#[test]
fn a_block_sliding_to_a_stop_on_an_incline_stops_at_the_closed_form_time() {
    let b = 20f64.to_radians();
    let (n, down) = ((b.sin(), b.cos()), (b.cos(), -b.sin()));
    let yaml = format!(
        r#"
duration: 3 s
gravity: [0, 0, -9.81]
integrator: {{ h: 1 ms, solver: {{ tolerance: 1e-12 }}, step_control: {{ tolerance: 1e-7, h_max: 50 ms, length: 1 m }} }}
bodies:
  - name: block
    mass: 1 kg
    shape: {{ box: {{ size: [0.2, 0.2, 0.05] }} }}
    orientation: {{ axis: [0, 1, 0], angle: 20 deg }}
    position: [{}, 0, {}]
    velocity: [{}, 0, {}]
contacts:
  - name: slope
    body: block
    shape: {{ box: {{ size: [0.2, 0.2, 0.05] }} }}
    against_shape: {{ plane: {{ normal: [{}, 0, {}] }} }}
    mu: 0.5
"#,
        0.025 * n.0,
        0.025 * n.1,
        2.0 * down.0,
        2.0 * down.1,
        n.0,
        n.1
    );
    let t_star = 2.0 / (G * (0.5 * b.cos() - b.sin()));
    let mut sim = scene(&yaml);
    let mut stop = None;
    let mut sizes = Vec::new();
    sim.run_until(2.5, |s, _| {
        if stop.is_none() && s.state.v.norm() < 1e-12 {
            stop = Some((s.state.t, s.h()));
        }
        sizes.push((s.state.t, s.h()));
    })
    .unwrap();
    let (stop, h) = stop.expect("the block stops");
    // the step that stops the block ends the first at rest: the stop lies within it, and
    // the control made it small (measured: 66 µs, 1.4e-5 s after t*; a fixed step of
    // 1 ms takes 1595 steps to the stop, the control 79 and 9 taken again)
    assert!(
        stop >= t_star && stop - t_star <= h,
        "stopped within the step ending at {stop} of {h:e} s, closed form {t_star}"
    );
    assert!(h < 1e-4, "the stopping step is {h:e} s");
    let before = sizes.iter().filter(|(t, _)| *t <= stop).count();
    assert!(before < 120, "{before} steps to the stop");
    // it slides at a constant deceleration, which the step takes exactly: at h_max
    let largest = sizes.iter().map(|x| x.1).fold(0.0, f64::max);
    assert!((largest - 0.05).abs() < 1e-12, "{largest}");
}

/// The arm's nose on the toggle clamp of tests/data/toggle-clamp.yaml with the handle at
/// `phi` (rad): the four-bar's closure, C on the branch above the line BD.
fn clamp_nose(phi: f64) -> (f64, f64) {
    let (a, b, c, d) = (0.030, 0.090, 0.040, (0.1, 0.0));
    let bx = (a * phi.cos(), a * phi.sin());
    let (dx, dy) = (d.0 - bx.0, d.1 - bx.1);
    let dist = dx.hypot(dy);
    let along = (dist * dist + b * b - c * c) / (2.0 * dist);
    let across = (b * b - along * along).sqrt();
    let (ex, ey) = (dx / dist, dy / dist);
    let cx = (
        bx.0 + along * ex - across * ey,
        bx.1 + along * ey + across * ex,
    );
    (d.0 + 1.5 * (d.0 - cx.0), d.1 + 1.5 * (d.1 - cx.1))
}

/// A toggle clamp locked over centre on its stop: its pad holds K δ, with δ from the
/// geometry of the rest (the handle 4° past the toggle) alone, and under step control the
/// locked mechanism takes few steps. The stop's contact has a singular block (the
/// handle turns about an ideal pivot), which the contact solver takes in closed form.
#[test]
fn a_toggle_clamp_locked_on_its_stop_holds_its_closed_form_force_in_few_steps() {
    // the toggle: A, B, C in line, |AC| = 120 mm, on the arm's circle |DC| = 40 mm about
    // D = (100 mm, 0): C's abscissa is (|AC|² − |DC|² + |AD|²) / (2 |AD|)
    let (ac, c, ad) = (0.120f64, 0.040f64, 0.1f64);
    let x = (ac * ac - c * c + ad * ad) / (2.0 * ad);
    let toggle = (ac * ac - x * x).sqrt().atan2(x);
    let nose = clamp_nose(toggle - 4f64.to_radians());
    // the pad's plane, as the scene writes it, and the nose's 5 mm sphere
    let (point, normal) = ((0.074597276411, -0.054559981986), (0.93674969976, -0.35));
    let depth = 0.005 - ((nose.0 - point.0) * normal.0 + (nose.1 - point.1) * normal.1);
    let closed_form = 1e6 * depth;
    assert!((depth - 1.0945e-4).abs() < 1e-7, "δ = {depth:e} m");

    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/toggle-clamp.yaml");
    let fixed = std::fs::read_to_string(&path).unwrap();
    let controlled = fixed.replace(
        "  scheme: combined-projection\n",
        "  scheme: combined-projection\n  step_control: { tolerance: 1e-4, h_max: 20 ms }\n",
    );
    assert_ne!(fixed, controlled);
    let options = mc_study::single_run::SimulateOptions {
        duration: None,
        trajectory: None,
        drawing: None,
    };
    for (yaml, label) in [(fixed, "fixed"), (controlled, "controlled")] {
        let scene = Scene::from_yaml(&yaml, "toggle clamp").unwrap_or_else(|e| panic!("{e}"));
        let report = mc_study::single_run::simulate(&scene, label, &options).unwrap();
        let force = report.probes[0].value.clone().unwrap();
        // δ is 0.11 mm; the joints hold to 1e-10 m (measured: 3e-9 fixed, 1.5e-6 controlled)
        assert!(
            (force / closed_form - 1.0).abs() < 1e-5,
            "{label}: clamp force {force} N, closed form {closed_form} N"
        );
        assert_eq!(report.stats.solver_failures, 0, "{label}");
        if label == "controlled" {
            // 444 in all (fixed: 4000); the 340 ms at rest take 17 of them, at h_max
            assert!(report.stats.steps < 600, "{} steps", report.stats.steps);
        }
    }
}
