//! Impacts located within their steps (`integrator: { locate_impacts: true }`): a box that
//! flies flat onto a plane, against its closed-form motion.

mod common;

use mc_study::scene::Scene;

const V0: f64 = 1.0;
const MASS: f64 = 2.0;

/// A 2 kg box, no gravity, flying flat at 1 m/s onto the plane z = 0 with restitution `e`;
/// its four lower corners touch at t* = `gap` / 1 m/s, at fraction 0.3 of a 1 ms step.
fn flat_box(e: f64, locate: bool, gap: f64) -> mc_study::integrator::Simulation {
    let yaml = format!(
        "
duration: 0.05 s
gravity: [0, 0, 0]
integrator: {{ h: 1 ms, locate_impacts: {locate} }}
bodies:
  - name: box
    mass: {MASS} kg
    shape: {{ box: {{ size: [0.2, 0.1, 0.05] }} }}
    position: [0, 0, {z}]
    velocity: [0, 0, -{V0}]
contacts:
  - name: floor
    body: box
    shape: {{ box: {{ size: [0.2, 0.1, 0.05] }} }}
    against: ground
    against_shape: {{ plane: {{ point: [0, 0, 0], normal: [0, 0, 1] }} }}
    mu: 0.3
    e: {e}
",
        z = 0.025 + gap
    );
    let scene = Scene::from_yaml(&yaml, "impacts").unwrap_or_else(|e| panic!("{e}"));
    common::simulation(scene)
}

/// Height of the box's centre at time t: down at V0 until t*, then up at e V0.
fn exact_z(e: f64, gap: f64, t: f64) -> f64 {
    let t_star = gap / V0;
    if t < t_star {
        0.025 + gap - V0 * t
    } else {
        0.025 + e * V0 * (t - t_star)
    }
}

/// Located, the impact is exact (to 1e-6 of the part of the step before it): the box leaves
/// at e V0 from the instant it touches, flat
/// (its four corners take the impact together), and the step's impulse is m (1 + e) V0.
/// Unlocated, the θ-rule moves the box over the impact's step with the mean of the two
/// velocities: it is h (s − ½)(1 + e) V0 off, 0.3 mm here, for good.
#[test]
fn a_located_impact_leaves_the_box_where_the_closed_form_motion_has_it() {
    for e in [0.0, 0.5, 1.0] {
        for gap in [0.0123, 0.0128, 0.01295] {
            let mut sim = flat_box(e, true, gap);
            let mut impulse = 0.0;
            sim.run_until(0.03, |s, _| {
                impulse += s.impulses().iter().map(|p| p.x).sum::<f64>();
            })
            .unwrap();
            let z = sim.state.poses[0].x.z;
            let err = (z - exact_z(e, gap, sim.state.t)).abs();
            // the part before the impact ends 1e-6 of itself short of the contact: the box
            // is 1e-6 s h (1 + e) V0 ≤ 1.5e-9 m off
            assert!(
                err < 2e-9,
                "e = {e}, t* = {gap} s: z = {z}, exact {}, |Δ| = {err:.2e}",
                exact_z(e, gap, sim.state.t)
            );
            assert!(
                (sim.state.v[2] - e * V0).abs() < 1e-10,
                "e = {e}: v_z = {}",
                sim.state.v[2]
            );
            let spin = sim.state.v.fixed_rows::<3>(3).norm();
            // one corner alone would turn it at about V0 / 0.1 m; 1e-8 is the solver's
            // round-off on four redundant corners
            assert!(spin < 1e-8, "e = {e}: the box turns at {spin} rad/s");
            assert!(
                (impulse - MASS * (1.0 + e) * V0).abs() < 1e-9,
                "e = {e}: total impulse {impulse}, m(1 + e)V0 = {}",
                MASS * (1.0 + e) * V0
            );
            assert_eq!(sim.stats.impact_splits, 1, "e = {e}: one step split");

            let mut plain = flat_box(e, false, gap);
            plain.run_until(0.03, |_, _| {}).unwrap();
            let z = plain.state.poses[0].x.z;
            let s = (gap % 1e-3) / 1e-3;
            let lag = 1e-3 * (s - 0.5).abs() * (1.0 + e) * V0;
            let err = (z - exact_z(e, gap, plain.state.t)).abs();
            assert!(
                e == 0.0 || err > 0.5 * lag,
                "e = {e}, s = {s}: unlocated |Δ| = {err:.2e}, expected about {lag:.2e}"
            );
        }
    }
}

/// The bouncing ball (e = 0.9, from 0.9 m) under the combined scheme: between its first two
/// impacts its energy above the resting height is e² m g g0. Located, the impact falls where
/// the secant through the step's parabola puts it, at most g h²/8 above the ground, which
/// costs at most (1 − e²) m g · g h²/8 of energy. Unlocated, the impact reflects the velocity
/// at the step's start, not at the impact: an error of first order, erratic with where the
/// impact falls in its step.
#[test]
fn a_located_bounce_keeps_the_restitution_energy_to_second_order() {
    let (e, gap0, g, r) = (0.9, 0.9, 9.81, 0.1);
    let energy_error = |h: f64, locate: bool| {
        let mut scene = common::bundled("bouncing-ball");
        scene.params.h = h;
        scene.params.scheme = mc_study::integrator::Scheme::CombinedProjection;
        scene.params.locate_impacts = locate;
        let mut sim = common::simulation(scene);
        sim.run_until(0.8, |_, _| {}).unwrap();
        let above = sim.energy() - g * r;
        (above - e * e * g * gap0).abs() / (g * gap0)
    };
    for h in [4e-3, 2e-3, 1e-3, 5e-4] {
        let located = energy_error(h, true);
        let bound = (1.0 - e * e) * g * h * h / 8.0 / gap0;
        assert!(
            located <= bound,
            "h = {h}: relative energy error {located:.3e} > {bound:.3e}"
        );
        let plain = energy_error(h, false);
        assert!(
            plain > 100.0 * located,
            "h = {h}: unlocated {plain:.3e}, located {located:.3e}"
        );
    }
}

/// A row of `n` equal balls, frictionless, e = 1, `gap` apart; the first strikes at 1 m/s,
/// the second drifts towards the third at `drift`. With gaps smaller than v·h, every
/// impact of the row falls in one step.
fn row_of_balls(
    n: usize,
    scheme: &str,
    locate: bool,
    gap: f64,
    drift: f64,
    h: f64,
) -> mc_study::integrator::Simulation {
    let mut yaml = format!(
        "
duration: 0.01 s
gravity: [0, 0, 0]
integrator: {{ h: {h}, scheme: {scheme}, locate_impacts: {locate} }}
bodies:
"
    );
    for k in 0..n {
        let v = match k {
            0 => ", velocity: [1, 0, 0]".to_string(),
            1 => format!(", velocity: [{drift}, 0, 0]"),
            _ => String::new(),
        };
        let x = k as f64 * (0.1 + gap);
        yaml += &format!(
            "  - {{ name: b{k}, mass: 1 kg, shape: {{ sphere: {{ radius: 0.05 }} }}, position: [{x}, 0, 0]{v} }}\n"
        );
    }
    yaml += "contacts:\n";
    for k in 1..n {
        yaml += &format!(
            "  - {{ name: c{k}, body: b{}, shape: {{ sphere: {{ radius: 0.05 }} }}, against: b{k}, against_shape: {{ sphere: {{ radius: 0.05 }} }}, mu: 0, e: 1 }}\n",
            k - 1
        );
    }
    let scene = Scene::from_yaml(&yaml, "row-of-balls").unwrap_or_else(|e| panic!("{e}"));
    common::simulation(scene)
}

/// Newton's cradle: impacts separate in time stay separate, even within one step. Taken
/// together, as one simultaneous impact, three balls would leave at (−1/3, 2/3, 2/3), which
/// the combined scheme returned: the impact that knocks the next contact shut is now split
/// from it, located or not. Located, the last ball is where the closed-form motion puts it
/// (it leaves at t = (n − 1) gap / v, from its place).
#[test]
fn a_row_of_balls_passes_the_blow_on_one_ball_at_a_time() {
    for n in [3, 5] {
        for (scheme, locate) in [
            ("moreau-jean", false),
            ("combined-projection", false),
            ("combined-projection", true),
        ] {
            let mut sim = row_of_balls(n, scheme, locate, 1e-4, 0.0, 1e-3);
            sim.run_until(0.01, |_, _| {}).unwrap();
            let v: Vec<f64> = (0..n).map(|k| sim.state.v[6 * k]).collect();
            for (k, vk) in v.iter().enumerate() {
                let exact = if k == n - 1 { 1.0 } else { 0.0 };
                assert!(
                    (vk - exact).abs() < 1e-9,
                    "{n} balls, {scheme}, located {locate}: velocities {v:?}"
                );
            }
            if scheme == "combined-projection" {
                assert!(sim.stats.max_penetration < 1e-12, "{scheme}: penetrates");
            }
            if locate {
                let x = sim.state.poses[n - 1].x.x;
                let exact = (n - 1) as f64 * (0.1 + 1e-4) + (0.01 - (n - 1) as f64 * 1e-4);
                assert!(
                    (x - exact).abs() < 1e-8,
                    "{n} balls: last at {x}, exact {exact}"
                );
            }
        }
    }
}

/// Newton's cradle in which the struck ball drifts towards the next one: in a real row
/// every ball moves a little. The blow still passes on one ball at a time: the last ball
/// leaves at 1 m/s and the others keep the drift between them, whatever the drift (1e-6 to
/// 1e-2 m/s), the gaps (10 and 50 µm, under v·h) and the step. Taken as one simultaneous
/// impact because the drifting contact was approaching, the three balls left at
/// (−1/3, 2/3, 2/3).
#[test]
fn a_drifting_row_of_balls_passes_the_blow_on_one_ball_at_a_time() {
    let n = 3;
    let mut wrong = Vec::new();
    for (scheme, locate) in [
        ("moreau-jean", false),
        ("combined-projection", false),
        ("combined-projection", true),
    ] {
        for h in [1e-3, 1e-4] {
            for gap in [1e-5, 5e-5] {
                for drift in [1e-6, 1e-4, 1e-2] {
                    let mut sim = row_of_balls(n, scheme, locate, gap, drift, h);
                    sim.run_until(0.01, |_, _| {}).unwrap();
                    let v: Vec<f64> = (0..n).map(|k| sim.state.v[6 * k]).collect();
                    let rest: f64 = v[..n - 1].iter().sum();
                    let one_out = (v[n - 1] - 1.0).abs() < 1e-9
                        && (rest - drift).abs() < 1e-9
                        && v[..n - 1]
                            .iter()
                            .all(|vk| *vk > -1e-9 && *vk < drift + 1e-9);
                    if !one_out {
                        wrong.push(format!(
                            "{scheme}, located {locate}, h {h}, gap {gap}, drift {drift}: {v:?}"
                        ));
                    }
                }
            }
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// A flat slider (a 0.1 × 0.04 × 0.02 m box, four corners on each face) thrown along a guide
/// 1 mm wider than it, bouncing between floor and roof: symmetric at the start, it must
/// stay flat, and its motion must not depend on the order of the contacts. Redundant
/// corners share an impact in whatever proportion the solver finds, so whether each ends
/// the impact separating is decided above round-off: a sign test on a round-off velocity
/// once kept two of the four corners closed and tilted the slider by 1.6e-5 rad.
#[test]
fn a_flat_slider_in_its_guide_stays_flat_whatever_the_contact_order() {
    let slider = |e: f64, mu: f64, locate: bool, roof_first: bool| {
        let face = |name: &str, z: f64, nz: i32| {
            format!(
                "  - {{ name: {name}, body: slider, shape: {{ box: {{ size: [0.1, 0.04, 0.02] }} }}, against: ground, against_shape: {{ plane: {{ point: [0, 0, {z}], normal: [0, 0, {nz}] }} }}, mu: {mu}, e: {e} }}\n"
            )
        };
        let (floor, roof) = (face("floor", 0.0, 1), face("roof", 0.021, -1));
        let contacts = if roof_first {
            roof + &floor
        } else {
            floor + &roof
        };
        let yaml = format!(
            "
duration: 0.5 s
integrator: {{ h: 1 ms, scheme: combined-projection, locate_impacts: {locate} }}
bodies:
  - {{ name: slider, mass: 0.5 kg, shape: {{ box: {{ size: [0.1, 0.04, 0.02] }} }}, position: [0, 0, 0.0105], velocity: [1, 0, -0.3] }}
contacts:
{contacts}"
        );
        let scene = Scene::from_yaml(&yaml, "slider").unwrap_or_else(|e| panic!("{e}"));
        let mut sim = common::simulation(scene);
        let mut tilt: f64 = 0.0;
        let mut path = Vec::new();
        sim.run_until(0.5, |s, _| {
            let q = s.state.poses[0].p;
            tilt = tilt.max(2.0 * q.i.abs()).max(2.0 * q.j.abs());
            path.push(s.state.poses[0].x);
        })
        .unwrap();
        (tilt, path)
    };
    for e in [0.0, 0.5] {
        for mu in [0.0, 0.2] {
            for locate in [false, true] {
                let (tilt, path) = slider(e, mu, locate, false);
                assert!(
                    tilt < 1e-9,
                    "e = {e}, μ = {mu}, located {locate}: tilt {tilt:.2e} rad"
                );
                let (_, reordered) = slider(e, mu, locate, true);
                let apart = path
                    .iter()
                    .zip(&reordered)
                    .map(|(a, b)| (a - b).norm())
                    .fold(0.0, f64::max);
                assert!(
                    apart < 1e-9,
                    "e = {e}, μ = {mu}: the contact order moves it {apart:.2e} m"
                );
            }
        }
    }
}

/// The largest gap, over a simulation's contact points, of one that carries load: a body
/// at rest must touch what holds it up, not hold it at a distance.
fn largest_loaded_gap(sim: &mc_study::integrator::Simulation) -> f64 {
    sim.contact_points()
        .iter()
        .zip(sim.impulses())
        .filter(|(_, p)| p.x > 0.0)
        .map(|(c, _)| c.gap())
        .fold(0.0, f64::max)
}

/// A block tilted by 0.1 rad on one edge, released: it rocks on its edges (e = 0, μ = 0.8),
/// its impacts located, and comes to rest on its face. The corners that carry it touch the
/// floor. An impact located a little short of its contact (the secant through the step's
/// parabola falls short by up to g h²/8) left the corner it stopped 3.3 µm above the floor,
/// carrying half the weight there for good.
#[test]
fn a_rocking_block_comes_to_rest_on_the_floor() {
    let yaml = "
duration: 3 s
integrator: { h: 1 ms, locate_impacts: true }
bodies:
  - name: block
    mass: 1 kg
    shape: { box: { size: [0.1 m, 0.05 m, 0.3 m] } }
    position: [0, 0, 0.16 m]
    orientation: { axis: [0, 1, 0], angle: 0.1 }
contacts:
  - name: floor
    body: block
    shape: { box: { size: [0.1 m, 0.05 m, 0.3 m] } }
    against_shape: { plane: { normal: [0, 0, 1] } }
    mu: 0.8
    e: 0
";
    let scene = Scene::from_yaml(yaml, "rocking").unwrap_or_else(|e| panic!("{e}"));
    let mut sim = common::simulation(scene);
    sim.run_until(3.0, |_, _| {}).unwrap();
    assert!(
        sim.stats.impact_splits > 3,
        "{} impacts",
        sim.stats.impact_splits
    );
    let load: f64 = sim.impulses().iter().map(|p| p.x).sum::<f64>() / sim.h();
    assert!((load - 9.81).abs() < 1e-9, "the floor carries {load} N");
    let gap = largest_loaded_gap(&sim);
    assert!(gap <= 1e-9, "a loaded corner {gap:e} m above the floor");
}

/// A ball (e = 0.5) bouncing to rest under gravity g at step h: once at rest it lies on
/// the floor. Newton's law on a contact the step's motion closes stops the ball where the
/// step begins; a closed contact takes no restitution, so a ball caught at a positive gap
/// stayed there, carrying its weight across up to g h²: 0.2 mm at h = 5 ms and 1.5 mm at
/// 10 ms under 9.81 m/s², 11 mm at 1 ms under 1e4 m/s², located or not.
#[test]
fn a_bouncing_ball_comes_to_rest_on_the_floor() {
    for (g, h) in [(9.81, 3e-3), (9.81, 5e-3), (9.81, 1e-2), (1e4, 1e-3)] {
        for locate in [false, true] {
            let yaml = format!(
                "
duration: 3 s
gravity: [0, 0, -{g}]
integrator: {{ h: {h}, locate_impacts: {locate} }}
bodies:
  - name: ball
    mass: 1 kg
    shape: {{ sphere: {{ radius: 0.1 m }} }}
    position: [0, 0, 1 m]
contacts:
  - name: floor
    body: ball
    shape: {{ sphere: {{ radius: 0.1 m }} }}
    against_shape: {{ plane: {{ normal: [0, 0, 1] }} }}
    e: 0.5
"
            );
            let scene = Scene::from_yaml(&yaml, "resting-ball").unwrap_or_else(|e| panic!("{e}"));
            let mut sim = common::simulation(scene);
            sim.run_until(3.0, |_, _| {}).unwrap();
            let load = sim.impulses()[0].x / sim.h();
            let gap = sim.contact_points()[0].gap();
            println!("g = {g}, h = {h}, located {locate}: gap {gap:e} m, load {load} N");
            assert!((load - g).abs() < 1e-9 * g, "the floor carries {load} N");
            assert!(
                gap.abs() <= 1e-9,
                "the ball rests {gap:e} m above the floor"
            );
        }
    }
}
