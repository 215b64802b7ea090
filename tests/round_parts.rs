//! Cylinders and cones against convex parts, boxes and planes: a cylinder rolls, or slides,
//! down a slope as the analytic solid cylinder does; a cylinder lying on a slab, or across
//! a narrow bar, carries its weight and stays level with friction; a cone lying on its side
//! shares its weight between apex and base as rigid statics says.

mod common;

use mc_study::integrator::Simulation;
use mc_study::scene::Scene;
use nalgebra::Vector3;

const G: f64 = 9.81;

/// The 8 corners of a box of half-sides `h` centred at `c`, as a YAML list of rows.
fn box_rows(h: [f64; 3], c: [f64; 3]) -> String {
    let rows: Vec<String> = (0..8)
        .map(|k| {
            let p = [0, 1, 2].map(|i| c[i] + if k & (1 << i) != 0 { h[i] } else { -h[i] });
            format!("[{}, {}, {}]", p[0], p[1], p[2])
        })
        .collect();
    rows.join(", ")
}

fn simulation(yaml: &str) -> Simulation {
    Scene::from_yaml(yaml, "round")
        .unwrap_or_else(|e| panic!("{e}"))
        .simulation()
        .unwrap()
}

/// The summed normal force of the candidates of the scene's only contact pair.
fn normal_force(sim: &Simulation) -> f64 {
    sim.impulses().iter().map(|p| p.x).sum::<f64>() / sim.h()
}

/// A solid cylinder (r = 20 mm, 0.3 m long, 0.5 kg) lying across a slope of 20°, its
/// axis horizontal, on a large convex slab, a box slab or a plane (gravity is tilted
/// instead of the slab). With μ = 0.5 it rolls: a = (2/3) g sin α, ω = v / r. With
/// μ = 0.05 < tan α / 3 it slides: a = g (sin α − μ cos α), and friction spins it up at
/// 2 μ g cos α / r. Each contact is a face against both end circles, whose rows do not
/// turn, so the θ-scheme reproduces the quadratic motion to round-off.
#[test]
fn a_cylinder_rolls_and_slides_down_a_slope_as_the_analytic_cylinder() {
    let a = 20f64.to_radians();
    let (r, m) = (0.02, 0.5);
    let slab = box_rows([2.0, 1.0, 0.05], [1.5, 0.0, -0.05]);
    for mu in [0.5, 0.05] {
        for against in [
            format!("{{ convex: {{ vertices: [{slab}] }} }}"),
            "{ box: { size: [4, 2, 0.1], center: [1.5, 0, -0.05] } }".to_string(),
            "{ plane: { normal: [0, 0, 1] } }".to_string(),
        ] {
            let yaml = format!(
                r#"
duration: 1 s
gravity: [{gx}, 0, {gz}]
integrator: {{ h: 1 ms, solver: {{ tolerance: 1e-12 }} }}
bodies:
  - {{ name: rod, mass: {m} kg, shape: {{ cylinder: {{ radius: {r}, length: 0.3 }} }}, orientation: {{ axis: [1, 0, 0], angle: 90 deg }}, position: [0, 0, {r}] }}
contacts:
  - name: seat
    body: rod
    shape: {{ cylinder: {{ radius: {r}, length: 0.3 }} }}
    against_shape: {against}
    mu: {mu}
"#,
                gx = G * a.sin(),
                gz = -G * a.cos(),
            );
            let mut sim = simulation(&yaml);
            let (accel, spin) = if mu > a.tan() / 3.0 {
                (2.0 / 3.0 * G * a.sin(), 2.0 / 3.0 * G * a.sin() / r)
            } else {
                (G * (a.sin() - mu * a.cos()), 2.0 * mu * G * a.cos() / r)
            };
            let mut worst: [f64; 3] = [0.0; 3];
            sim.run_until(1.0, |s, _| {
                let t = s.state.t;
                let x = s.state.poses[0].x;
                let omega = s.state.poses[0].p * s.state.twist(0).fixed_rows::<3>(3).into_owned();
                worst[0] = worst[0].max((x.x - 0.5 * accel * t * t).abs());
                worst[1] = worst[1].max((x.z - r).abs() + x.y.abs());
                worst[2] = worst[2].max((omega.y - spin * t).abs() / (spin * t).max(1e-3));
            })
            .unwrap();
            println!("μ = {mu}, {against}: distance along {:.2e} m, off the slope {:.2e} m, spin {:.2e} relative", worst[0], worst[1], worst[2]);
            assert!(
                worst[0] < 1e-9 * 0.5 * accel,
                "μ = {mu}, {against}: {worst:?}"
            );
            assert!(worst[1] < 1e-10, "μ = {mu}, {against}: {worst:?}");
            assert!(worst[2] < 1e-9, "μ = {mu}, {against}: {worst:?}");
            let weight = m * G * a.cos();
            assert!(
                (normal_force(&sim) / weight - 1.0).abs() < 1e-9,
                "{} N against {weight} N",
                normal_force(&sim)
            );
        }
    }
}

/// A cylinder 0.2 m long dropped 0.5 mm with μ = 0.3 lands on both end circles and rests
/// level, carrying m g: on a convex slab, and on a mesh floor whose triangles' sides run
/// under its end circles. One dropped across a bar 10 mm wide, which no end circle and
/// no corner of the bar reaches, rests on the bar's two top edges.
#[test]
fn a_cylinder_rests_level_on_a_slab_a_mesh_and_across_a_narrow_bar() {
    let (r, m) = (0.02, 0.5);
    let dir = common::scratch("round_parts_floor");
    std::fs::write(dir.join("floor.obj"), common::floor_obj()).unwrap();
    for (label, against) in [
        (
            "slab",
            format!(
                "{{ convex: {{ vertices: [{}] }} }}",
                box_rows([0.5, 0.5, 0.05], [0.0, 0.0, -0.05])
            ),
        ),
        (
            "mesh",
            "{ mesh: { file: floor.obj, scale: 1 mm } }".to_string(),
        ),
        (
            "bar",
            format!(
                "{{ convex: {{ vertices: [{}] }} }}",
                box_rows([0.005, 0.1, 0.05], [0.0, 0.0, -0.05])
            ),
        ),
    ] {
        let yaml = format!(
            r#"
duration: 1 s
integrator: {{ h: 1 ms, solver: {{ tolerance: 1e-12 }} }}
bodies:
  - {{ name: rod, mass: {m} kg, shape: {{ cylinder: {{ radius: {r}, length: 0.2 }} }}, orientation: {{ axis: [0, 1, 0], angle: 90 deg }}, position: [0, 0, 0.0205] }}
contacts:
  - name: seat
    body: rod
    shape: {{ cylinder: {{ radius: {r}, length: 0.2 }} }}
    against_shape: {against}
    mu: 0.3
"#
        );
        let path = dir.join("scene.yaml");
        std::fs::write(&path, &yaml).unwrap();
        let mut sim = Scene::load(&path)
            .unwrap_or_else(|e| panic!("{e}"))
            .simulation()
            .unwrap();
        sim.run_until(1.0, |_, _| {}).unwrap();
        let pose = sim.state.poses[0];
        let axis = pose.p * Vector3::z();
        println!(
            "{label}: tilt {:.2e}, height {:.2e} off, force {} N",
            axis.z,
            pose.x.z - r,
            normal_force(&sim)
        );
        assert!(axis.z.abs() < 1e-9, "{label}: tilt {:e}", axis.z);
        assert!((pose.x.z - r).abs() < 1e-10, "{label}: {}", pose.x.z);
        assert!(
            (normal_force(&sim) / (m * G) - 1.0).abs() < 1e-9,
            "{label}: {} N",
            normal_force(&sim)
        );
        assert!(
            sim.state.v.norm() < 1e-9,
            "{label}: {:e}",
            sim.state.v.norm()
        );
    }
}

/// A solid cone (R = 20 mm, H = 40 mm, 0.2 kg) lying on its side touches along a
/// generator, at its apex and at its base circle. Rigid statics about the apex: the base
/// carries m g (3/4) H² / (H² + R²) = 0.6 m g, the apex the rest, on a plane, a convex
/// slab and a box; with friction, and at rest. On the slab and the box the apex lies over
/// the diagonal that splits the top face into two triangles: a point there must take the
/// face's normal, not the direction from the diagonal (with that, the apex's normal
/// tilted, friction held the tilt, and the apex carried 0.438 m g).
#[test]
fn a_cone_on_its_side_shares_its_weight_between_apex_and_base() {
    let (rr, hh, m): (f64, f64, f64) = (0.02, 0.04, 0.2);
    let beta = (rr / hh).atan();
    // axis from base to apex, (−cos β, 0, −sin β): a turn of −(90° + β) about y; the
    // centroid lies 3H/4 from the apex, the cone's centre H/4 from the centroid
    let angle = -(90f64.to_radians() + beta);
    let centroid = Vector3::new(beta.cos(), 0.0, beta.sin()) * (0.75 * hh);
    let i_axis = 0.3 * m * rr * rr;
    let i_perp = 0.15 * m * rr * rr + 0.0375 * m * hh * hh;
    let slab = box_rows([0.2, 0.2, 0.05], [0.0, 0.0, -0.05]);
    for against in [
        "{ plane: { normal: [0, 0, 1] } }".to_string(),
        format!("{{ convex: {{ vertices: [{slab}] }} }}"),
        "{ box: { size: [0.4, 0.4, 0.1], center: [0, 0, -0.05] } }".to_string(),
    ] {
        let yaml = format!(
            r#"
duration: 0.5 s
integrator: {{ h: 1 ms, solver: {{ tolerance: 1e-12 }} }}
bodies:
  - name: cone
    mass: {m} kg
    inertia: [{i_perp}, {i_perp}, {i_axis}]
    orientation: {{ axis: [0, 1, 0], angle: {angle} }}
    position: [{}, 0, {}]
contacts:
  - name: seat
    body: cone
    shape: {{ cone: {{ radius: {rr}, length: {hh}, center: [0, 0, {}] }} }}
    against_shape: {against}
    mu: 0.3
"#,
            centroid.x,
            centroid.z,
            0.25 * hh,
        );
        let mut sim = simulation(&yaml);
        sim.run_until(0.5, |_, _| {}).unwrap();
        let h = sim.h();
        let (base, apex) = (sim.impulses()[0].x / h, sim.impulses()[1].x / h);
        let rest: f64 = sim.impulses()[2..].iter().map(|p| p.x.abs()).sum::<f64>() / h;
        println!(
            "{against}: base {:.12} m g, apex {:.12} m g, other candidates {rest:e} N, speed {:e}",
            base / (m * G),
            apex / (m * G),
            sim.state.v.norm()
        );
        assert!(
            (base / (0.6 * m * G) - 1.0).abs() < 1e-9,
            "{against}: base {base} N"
        );
        assert!(
            (apex / (0.4 * m * G) - 1.0).abs() < 1e-9,
            "{against}: apex {apex} N"
        );
        assert!(rest < 1e-9, "{against}: {rest} N elsewhere");
        assert!(sim.state.v.norm() < 1e-9, "{against}: moves");
        assert!(sim.stats.max_penetration < 1e-10);
    }
}

/// Pairs the engine cannot take are refused with both shapes named, and a cone's fields
/// are checked like a cylinder's.
#[test]
fn cones_are_checked_like_cylinders() {
    let scene = |shape: &str, against: &str| {
        Scene::from_yaml(
            &format!(
                "duration: 1 s\nbodies:\n  - {{ name: a, mass: 1 kg, shape: {{ sphere: {{ radius: 0.1 }} }} }}\ncontacts:\n  - {{ body: a, shape: {shape}, against_shape: {against} }}\n"
            ),
            "bad.yaml",
        )
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default()
    };
    let e = scene(
        "{ cone: { radius: 0.1, length: 0.2 } }",
        "{ sphere: { radius: 0.1 } }",
    );
    assert!(e.contains("cone") && e.contains("sphere"), "{e}");
    let e = scene(
        "{ cone: { radius: -0.1, length: 0.2 } }",
        "{ plane: { normal: [0, 0, 1] } }",
    );
    assert!(e.contains("cone.radius") && e.contains("bad.yaml:5"), "{e}");
    let ok = scene(
        "{ cone: { radius: 0.1, length: 0.2 } }",
        "{ box: { size: [1, 1, 1] } }",
    );
    assert!(ok.is_empty(), "{ok}");
}
