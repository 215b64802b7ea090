//! Convex parts and meshes: a box given as a convex polyhedron (a vertex list, and an STL
//! file) slides down the incline exactly as the analytic box does; a sphere resting on a
//! mesh frame carries m g; a cube rests flat on a convex slab; bad input names its field.

mod common;

use common::scratch;
use mc_study::integrator::Simulation;
use mc_study::scene::Scene;
use mc_study::study::Subject;
use nalgebra::Vector3;
use std::path::Path;

const G: f64 = 9.81;
const SIZE: [f64; 3] = [0.2, 0.2, 0.05];

/// The 8 corners of a box of half-sides `h` centred at `c`, corner k at +h along the axes
/// whose bits (1, 2, 4) k has.
fn box_corners(h: [f64; 3], c: [f64; 3]) -> Vec<[f64; 3]> {
    (0..8)
        .map(|k| [0, 1, 2].map(|i| c[i] + if k & (1 << i) != 0 { h[i] } else { -h[i] }))
        .collect()
}

/// Corners as a YAML list of rows, for `convex: { vertices }`.
fn rows(corners: &[[f64; 3]]) -> String {
    let rows: Vec<String> = corners
        .iter()
        .map(|c| format!("[{}, {}, {}]", c[0], c[1], c[2]))
        .collect();
    rows.join(", ")
}

/// The 8 corners of the incline's block.
fn corners() -> Vec<[f64; 3]> {
    box_corners(SIZE.map(|e| 0.5 * e), [0.0; 3])
}

/// An ASCII STL of the block (mm), 12 outward triangles.
fn block_stl() -> String {
    let c = corners();
    // faces as corner quads, counter-clockwise from outside
    let quads = [
        [0, 2, 3, 1], // −z
        [4, 5, 7, 6], // +z
        [0, 1, 5, 4], // −y
        [2, 6, 7, 3], // +y
        [0, 4, 6, 2], // −x
        [1, 3, 7, 5], // +x
    ];
    let mut s = String::from("solid block\n");
    for q in quads {
        for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            s += "  facet normal 0 0 0\n    outer loop\n";
            for i in t {
                let p = c[i].map(|x| x * 1000.0);
                s += &format!("      vertex {} {} {}\n", p[0], p[1], p[2]);
            }
            s += "    endloop\n  endfacet\n";
        }
    }
    s + "endsolid block\n"
}

/// The incline scene of `tests/incline.rs` (20°, μ = 0.5, 2 m/s down the slope), with the
/// block's contact shape `shape`.
fn incline_yaml(shape: &str) -> String {
    let b = 20f64.to_radians();
    let n = Vector3::new(b.sin(), 0.0, b.cos());
    let down = Vector3::new(b.cos(), 0.0, -b.sin());
    let c = n * 0.025;
    let v = down * 2.0;
    format!(
        r#"
duration: 3 s
integrator: {{ h: 1 ms, solver: {{ tolerance: 1e-12 }} }}
bodies:
  - name: block
    mass: 1 kg
    shape: {{ box: {{ size: [0.2, 0.2, 0.05] }} }}
    orientation: {{ axis: [0, 1, 0], angle: 20 deg }}
    position: [{}, {}, {}]
    velocity: [{}, {}, {}]
contacts:
  - name: slope
    body: block
    shape: {shape}
    against_shape: {{ plane: {{ normal: [{}, {}, {}] }} }}
    mu: 0.5
"#,
        c.x, c.y, c.z, v.x, v.y, v.z, n.x, n.y, n.z
    )
}

fn load(dir: &Path, yaml: &str) -> Simulation {
    let path = dir.join("scene.yaml");
    std::fs::write(&path, yaml).unwrap();
    Scene::load(&path)
        .unwrap_or_else(|e| panic!("{e}"))
        .simulation()
        .unwrap()
}

/// Block positions at every step, and the first time its speed falls below 1e-9 m/s.
fn trajectory(mut sim: Simulation) -> (Vec<Vector3<f64>>, f64, f64) {
    let mut xs = Vec::new();
    let mut stop = f64::NAN;
    let mut creep: f64 = 0.0;
    sim.run_until(3.0, |s, _| {
        xs.push(s.state.poses[0].x);
        let speed = s.state.v.norm();
        if stop.is_nan() && speed < 1e-9 {
            stop = s.state.t;
        }
        if !stop.is_nan() {
            creep = creep.max(speed);
        }
    })
    .unwrap();
    (xs, stop, creep)
}

#[test]
fn a_box_given_as_a_convex_part_slides_and_stops_as_the_analytic_box() {
    let dir = scratch("convex_incline");
    std::fs::write(dir.join("block.stl"), block_stl()).unwrap();
    let (reference, t_box, _) = trajectory(load(
        &dir,
        &incline_yaml("{ box: { size: [0.2, 0.2, 0.05] } }"),
    ));
    let b = 20f64.to_radians();
    let t_star = 2.0 / (G * (0.5 * b.cos() - b.sin()));
    for shape in [
        format!("{{ convex: {{ vertices: [{}] }} }}", rows(&corners())),
        "{ convex: { file: block.stl, scale: 1 mm } }".to_string(),
    ] {
        let (xs, stop, creep) = trajectory(load(&dir, &incline_yaml(&shape)));
        let worst = xs
            .iter()
            .zip(&reference)
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, f64::max);
        println!("{shape}: largest distance to the box's trajectory {worst:e} m, stop {stop} s (analytic {t_star}), creep {creep:e}");
        assert_eq!(xs.len(), reference.len());
        assert!(worst < 1e-9, "{shape}: {worst:e} m");
        assert!(
            (stop - t_box).abs() < 1e-12,
            "{shape}: stops at {stop}, the box at {t_box}"
        );
        assert!(
            (stop - t_star).abs() <= 1e-3,
            "{shape}: stops at {stop}, analytic {t_star}"
        );
        assert!(creep < 1e-9, "{shape}: creeps at {creep:e} m/s");
    }
}

/// Spheres resting on the mesh floor, one on a face, one on an edge and one on a vertex
/// shared by six triangles: each contact carries m g to 1e-9, and none sinks in.
#[test]
fn a_sphere_resting_on_a_mesh_carries_its_weight() {
    let dir = scratch("mesh_floor");
    std::fs::write(dir.join("floor.obj"), common::floor_obj()).unwrap();
    for (x, y, where_) in [
        (0.02, 0.03, "face"),
        (0.0, 0.03, "edge"),
        (0.05, 0.05, "vertex"),
    ] {
        let yaml = format!(
            r#"
duration: 1 s
integrator: {{ h: 1 ms, solver: {{ tolerance: 1e-12 }} }}
bodies:
  - {{ name: ball, mass: 2 kg, shape: {{ sphere: {{ radius: 20 mm }} }}, position: [{x}, {y}, 0.02] }}
contacts:
  - name: floor
    body: ball
    shape: {{ sphere: {{ radius: 20 mm }} }}
    against_shape: {{ mesh: {{ file: floor.obj, scale: 1 mm }} }}
probes:
  - {{ name: weight, measure: {{ contact_force: floor }}, reduce: mean, from: 0.5 s }}
  - {{ name: height, measure: {{ distance: {{ from: {{ body: ground }}, to: {{ body: ball }}, axis: [0, 0, 1] }} }} }}
"#
        );
        let path = dir.join("scene.yaml");
        std::fs::write(&path, &yaml).unwrap();
        let subject =
            Subject::from_yaml(&yaml, path.to_str().unwrap()).unwrap_or_else(|e| panic!("{e}"));
        let o = subject.run(&[], &[0, 1]);
        assert!(o.error.is_none(), "{where_}: {:?}", o.error);
        let (weight, height) = (o.outputs[0], o.outputs[1]);
        println!("on a {where_}: contact force {weight} N, height {height} m");
        assert!(
            (weight / (2.0 * G) - 1.0).abs() < 1e-9,
            "{where_}: {weight} N"
        );
        assert!((height - 0.02).abs() < 1e-10, "{where_}: {height} m");
    }
}

/// A cube given by its vertices rests on a fixed convex slab: it stays flat (a face on a
/// face touches at the four corners) and the slab carries its weight.
#[test]
fn a_convex_cube_rests_flat_on_a_convex_slab() {
    let cube = rows(&box_corners([0.025; 3], [0.0; 3]));
    let slab = rows(&box_corners([0.2, 0.15, 0.01], [0.0, 0.0, -0.01]));
    let yaml = format!(
        r#"
duration: 1 s
integrator: {{ h: 1 ms, solver: {{ tolerance: 1e-12 }} }}
bodies:
  - {{ name: cube, mass: 1 kg, shape: {{ box: {{ size: [0.05, 0.05, 0.05] }} }}, position: [0.03, -0.02, 0.0251] }}
contacts:
  - name: seat
    body: cube
    shape: {{ convex: {{ vertices: [{}] }} }}
    against_shape: {{ convex: {{ vertices: [{}] }} }}
    mu: 0.3
probes:
  - {{ name: weight, measure: {{ contact_force: seat }}, reduce: mean, from: 0.5 s }}
  - {{ name: height, measure: {{ distance: {{ from: {{ body: ground }}, to: {{ body: cube }}, axis: [0, 0, 1] }} }} }}
"#,
        cube, slab
    );
    let scene = Scene::from_yaml(&yaml, "cube").unwrap_or_else(|e| panic!("{e}"));
    let mut sim = scene.simulation().unwrap();
    sim.run_until(1.0, |_, _| {}).unwrap();
    let tilt = (sim.state.poses[0].p * Vector3::z()).angle(&Vector3::z());
    assert!(tilt < 1e-9, "tilt {tilt:e} rad");
    assert!(
        (sim.state.poses[0].x.z - 0.025).abs() < 1e-10,
        "{}",
        sim.state.poses[0].x.z
    );
    let subject = Subject::from_yaml(&yaml, "cube").unwrap();
    let o = subject.run(&[], &[0]);
    assert!((o.outputs[0] / G - 1.0).abs() < 1e-9, "{} N", o.outputs[0]);
}

/// Bad parts are refused with the field and line: a missing file, points that are not
/// convex, a mesh that is not convex given as convex, degenerate and non-manifold meshes.
#[test]
fn bad_convex_parts_and_meshes_name_the_field() {
    let dir = scratch("bad_meshes");
    let tri = |a: [f64; 3], b: [f64; 3], c: [f64; 3]| {
        format!(
            "  facet normal 0 0 0\n    outer loop\n      vertex {} {} {}\n      vertex {} {} {}\n      vertex {} {} {}\n    endloop\n  endfacet\n",
            a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]
        )
    };
    let stl = |body: String| format!("solid x\n{body}endsolid x\n");
    std::fs::write(
        dir.join("degenerate.stl"),
        stl(tri([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0])),
    )
    .unwrap();
    // three triangles on the edge (0,0,0)–(1,0,0)
    std::fs::write(
        dir.join("fin.stl"),
        stl(tri([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
            + &tri([1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, -1.0, 0.0])
            + &tri([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0])),
    )
    .unwrap();
    // an open, non-convex surface: a V
    std::fs::write(
        dir.join("vee.stl"),
        stl(tri([0.0, 0.0, 0.0], [1.0, 0.0, 1.0], [0.0, 1.0, 0.0])
            + &tri([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 1.0])
            + &tri([0.0, 0.0, 0.0], [-1.0, 0.0, 1.0], [0.0, -1.0, 0.0])
            + &tri([0.0, 0.0, 0.0], [0.0, -1.0, 0.0], [1.0, 0.0, 1.0])),
    )
    .unwrap();
    let scene = |shape: &str| {
        format!(
            "name: bad\nduration: 1\nbodies:\n  - {{ name: b, mass: 1, inertia: [1, 1, 1] }}\ncontacts:\n  - body: b\n    shape: {{ sphere: {{ radius: 0.1 }} }}\n    against_shape:\n      {shape}\n"
        )
    };
    let cases = [
        (
            "mesh: { file: missing.stl, scale: 1 mm }",
            "mesh.file",
            "cannot read mesh file",
        ),
        (
            "mesh: { file: degenerate.stl, scale: 1 mm }",
            "mesh.file",
            "degenerate",
        ),
        (
            "mesh: { file: fin.stl, scale: 1 mm }",
            "mesh.file",
            "not manifold",
        ),
        ("mesh: { file: fin.stl }", "", "missing field `scale`"),
        (
            "convex: { file: vee.stl, scale: 1 mm }",
            "convex.file",
            "not convex",
        ),
        (
            "convex: { vertices: [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0.1, 0.1, 0.1]] }",
            "convex",
            "not convex",
        ),
        (
            "convex: { vertices: [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]] }",
            "convex",
            "flat",
        ),
    ];
    for (shape, field, what) in cases {
        let path = dir.join("scene.yaml");
        std::fs::write(&path, scene(shape)).unwrap();
        let e = Scene::load(&path).expect_err(shape);
        assert_eq!(e.line, Some(9), "{shape}: {e}");
        assert!(e.field.contains(field), "{shape}: {e}");
        assert!(e.message.contains(what), "{shape}: {e}");
    }
}

/// A capsule dropped lengthwise onto a convex slab rests on both end spheres: level, at
/// its radius above the slab, carrying its weight.
#[test]
fn a_capsule_rests_level_on_a_convex_slab() {
    let slab = rows(&box_corners([0.5, 0.5, 0.05], [0.0, 0.0, -0.05]));
    let yaml = format!(
        r#"
duration: 1 s
integrator: {{ h: 1 ms, solver: {{ tolerance: 1e-12 }} }}
bodies:
  - {{ name: rod, mass: 0.5 kg, shape: {{ cylinder: {{ radius: 20 mm, length: 0.3 }} }}, orientation: {{ axis: [0, 1, 0], angle: 90 deg }}, position: [0.05, 0.1, 0.0205] }}
contacts:
  - name: seat
    body: rod
    shape: {{ capsule: {{ radius: 20 mm, length: 0.3 }} }}
    against_shape: {{ convex: {{ vertices: [{}] }} }}
    mu: 0.3
probes:
  - {{ name: weight, measure: {{ contact_force: seat }}, reduce: mean, from: 0.5 s }}
"#,
        slab
    );
    let scene = Scene::from_yaml(&yaml, "rod").unwrap_or_else(|e| panic!("{e}"));
    let mut sim = scene.simulation().unwrap();
    sim.run_until(1.0, |_, _| {}).unwrap();
    let axis = sim.state.poses[0].p * Vector3::z();
    assert!(axis.z.abs() < 1e-9, "tilt {:e}", axis.z);
    assert!(
        (sim.state.poses[0].x.z - 0.02).abs() < 1e-10,
        "{}",
        sim.state.poses[0].x.z
    );
    let o = Subject::from_yaml(&yaml, "rod").unwrap().run(&[], &[0]);
    assert!(
        (o.outputs[0] / (0.5 * G) - 1.0).abs() < 1e-9,
        "{} N",
        o.outputs[0]
    );
}

/// A binary STL of `triangles` (corner coordinates in file units), 32-bit floats.
fn binary_stl(triangles: &[[[f64; 3]; 3]]) -> Vec<u8> {
    let mut b = vec![0u8; 80];
    b.extend((triangles.len() as u32).to_le_bytes());
    for t in triangles {
        b.extend([0u8; 12]);
        for v in t {
            for x in v {
                b.extend((*x as f32).to_le_bytes());
            }
        }
        b.extend([0u8; 2]);
    }
    b
}

/// A 16 × 8 UV sphere of radius `r` about `c`, wound outward.
fn uv_sphere(r: f64, c: [f64; 3]) -> Vec<[[f64; 3]; 3]> {
    let (seg, rings) = (16, 8);
    let p = |i: usize, j: usize| {
        let (th, ph) = (
            std::f64::consts::PI * i as f64 / rings as f64,
            2.0 * std::f64::consts::PI * j as f64 / seg as f64,
        );
        [
            c[0] + r * th.sin() * ph.cos(),
            c[1] + r * th.sin() * ph.sin(),
            c[2] + r * th.cos(),
        ]
    };
    let mut out = Vec::new();
    for i in 0..rings {
        for j in 0..seg {
            let (a, b, cc, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            if i > 0 {
                out.push([a, b, d]);
            }
            if i + 1 < rings {
                out.push([b, cc, d]);
            }
        }
    }
    // outward: the normal points away from the centre
    for t in &mut out {
        let v = |k: usize| Vector3::from(t[k]);
        let n = (v(1) - v(0)).cross(&(v(2) - v(0)));
        if n.dot(&(v(0) - Vector3::from(c))) < 0.0 {
            t.swap(1, 2);
        }
    }
    out
}

/// Geometry files that would mislead are refused with their real cause: a NaN or infinite
/// coordinate (ASCII STL, binary STL, OBJ, inline vertices), a coordinate far beyond any
/// mechanism, an ASCII STL cut short, a device file; and a convex part exported as a
/// binary STL, whose 32-bit coordinates sit a little off its faces, is accepted as it is
/// in ASCII.
#[test]
fn hostile_geometry_files_are_refused_with_their_cause() {
    let dir = scratch("hostile_meshes");
    let facet = |a: &str| {
        format!("  facet normal 0 0 0\n    outer loop\n      vertex {a}\n      vertex 1 0 0\n      vertex 0 1 0\n    endloop\n  endfacet\n")
    };
    std::fs::write(
        dir.join("nan.stl"),
        format!("solid x\n{}endsolid x\n", facet("nan 0 0")),
    )
    .unwrap();
    std::fs::write(
        dir.join("huge.stl"),
        format!("solid x\n{}endsolid x\n", facet("1e300 0 0")),
    )
    .unwrap();
    std::fs::write(
        dir.join("cut.stl"),
        format!("solid x\n{}{}", facet("0 0 0"), facet("0 0 1")),
    )
    .unwrap();
    let mut bin = uv_sphere(10.0, [0.0, 0.0, 0.0]);
    bin[3][1][2] = f64::NAN;
    std::fs::write(dir.join("nan-binary.stl"), binary_stl(&bin)).unwrap();
    std::fs::write(
        dir.join("inf.obj"),
        "v inf 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let sphere = uv_sphere(10.0, [30.0, 20.0, 10.0]);
    std::fs::write(dir.join("sphere.stl"), binary_stl(&sphere)).unwrap();
    let scene = |shape: &str| {
        format!(
            "name: bad\nduration: 1\nbodies:\n  - {{ name: b, mass: 1, inertia: [1, 1, 1] }}\ncontacts:\n  - body: b\n    shape: {{ sphere: {{ radius: 0.1 }} }}\n    against_shape:\n      {shape}\n"
        )
    };
    let cases = [
        (
            "mesh: { file: nan.stl, scale: 1 mm }",
            "line 4: the coordinate NaN is not a finite number",
        ),
        (
            "mesh: { file: nan-binary.stl, scale: 1 mm }",
            "facet 3, vertex 1: the coordinate NaN is not a finite number",
        ),
        (
            "mesh: { file: inf.obj, scale: 1 mm }",
            "line 1: the coordinate inf is not a finite number",
        ),
        (
            "convex: { file: nan.stl, scale: 1 mm }",
            "not a finite number",
        ),
        (
            "convex: { vertices: [[.nan, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]] }",
            "non-finite float",
        ),
        (
            "mesh: { file: huge.stl, scale: 1 mm }",
            "is `scale` or the file's unit wrong?",
        ),
        (
            "mesh: { file: cut.stl, scale: 1 mm }",
            "a truncated or malformed ASCII STL",
        ),
        (
            "mesh: { file: /dev/zero, scale: 1 mm }",
            "not a regular file",
        ),
    ];
    for (shape, what) in cases {
        let path = dir.join("scene.yaml");
        std::fs::write(&path, scene(shape)).unwrap();
        let e = Scene::load(&path).expect_err(shape);
        assert_eq!(e.line, Some(9), "{shape}: {e}");
        assert!(e.message.contains(what), "{shape}: {e}");
    }
    // the UV sphere as a convex part, binary and ASCII alike
    let path = dir.join("scene.yaml");
    std::fs::write(&path, scene("convex: { file: sphere.stl, scale: 1 mm }")).unwrap();
    Scene::load(&path).unwrap_or_else(|e| panic!("binary STL sphere: {e}"));
}
