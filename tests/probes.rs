//! Scene probes against closed forms on the ball: a distance at a time, a threshold
//! crossing, contact close/open events, mean contact forces over windows; and their
//! errors (an event that never happens, bad references).

use mc_study::study::Subject;

fn ball(e: f64, probes: &str) -> String {
    format!(
        r#"
name: probe-ball
duration: 2 s
integrator: {{ h: 1 ms, scheme: moreau-jean }}
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
    e: {e}
probes:
{probes}"#
    )
}

fn run(text: &str) -> Result<Vec<f64>, String> {
    let s = Subject::from_yaml(text, "probe-ball.yaml").map_err(|e| e.to_string())?;
    let n = s.outputs().len();
    let o = s.run(&[], &(0..n).collect::<Vec<_>>());
    match o.error {
        Some(e) => Err(e),
        None => Ok(o.outputs),
    }
}

#[test]
fn distance_at_a_time_and_a_threshold_crossing_in_free_fall() {
    let probes = r#"
  - name: height_at_200ms
    measure: { distance: { from: { body: ground }, to: { body: ball }, axis: [0, 0, 1] } }
    at: 200 ms
  - name: height_at_200_5ms
    measure: { distance: { from: { body: ground }, to: { body: ball }, axis: [0, 0, 1] } }
    at: 200.5 ms
  - name: half_metre
    event: { crosses: 0.5 m, measure: { distance: { from: { body: ground }, to: { body: ball }, axis: [0, 0, 1] } }, direction: down }
"#;
    let v = run(&ball(0.0, probes)).unwrap();
    // the θ = 1/2 position update is exact under constant gravity
    let z = |t: f64| 1.0 - 0.5 * 9.81 * t * t;
    assert!((v[0] - z(0.2)).abs() < 1e-12, "{} vs {}", v[0], z(0.2));
    // between steps: linear interpolation, error g h²/8 at most
    assert!(
        (v[1] - z(0.2005)).abs() < 9.81 * 1e-6 / 8.0 + 1e-12,
        "{}",
        v[1]
    );
    let t_half = (2.0 * 0.5 / 9.81f64).sqrt();
    assert!((v[2] - t_half).abs() < 1e-6, "{} vs {t_half}", v[2]);
}

#[test]
fn contact_events_and_mean_force_at_rest() {
    let probes = r#"
  - name: impact
    event: { closes: floor }
  - name: leaves
    event: { opens: floor }
  - name: second_impact
    event: { closes: floor, occurrence: 2 }
"#;
    let v = run(&ball(0.9, probes)).unwrap();
    let t1 = (2.0 * 0.9 / 9.81f64).sqrt();
    // timed within the step by the free flight of the step-start gap at the previous
    // step's gap rate: gravity shifts that rate by g h / 2 and bends the flight over τ ≤ h,
    // an error of at most g h τ / |u| ≤ 2.4e-6 s at 4.2 m/s (the step end, the
    // event-capturing time, is up to h = 1e-3 s off)
    println!("impact at {:.9} s, closed form {t1:.9} s", v[0]);
    assert!((v[0] - t1).abs() <= 2.4e-6, "{} vs {t1}", v[0]);
    // the ball is in contact for exactly the impact step, which ends after the impact
    let step_end = v[1] - 1e-3;
    assert!(
        step_end > v[0] && step_end - v[0] <= 1e-3,
        "{} {}",
        v[0],
        v[1]
    );
    let flight = 2.0 * 0.9 * (2.0 * 9.81 * 0.9f64).sqrt() / 9.81;
    println!("flight {:.9} s, closed form {flight:.9} s", v[2] - v[0]);
    assert!((v[2] - v[0] - flight).abs() < 1e-3, "{}", v[2] - v[0]);

    let rest = r#"
  - name: weight
    measure: { contact_force: floor }
    reduce: mean
    from: 1 s
    to: 2 s
  - name: lowest
    measure: { gap: floor }
    reduce: min
"#;
    let v = run(&ball(0.0, rest)).unwrap();
    assert!((v[0] - 9.81).abs() < 1e-9, "{}", v[0]);
    assert!(v[1].abs() < 1e-3, "{}", v[1]);
}

/// A mean over a window is ∫F dt / (to − from): the ball (e = 0) lands at t₁ with speed
/// v₁ and then rests, so the floor's mean force from the landing to T is
/// (m v₁ + m g (T − t₁)) / (T − t₁), the impact's impulse included. T falls mid-step: the
/// last step counts for its half inside the window (counting whole steps, as a step-count
/// mean would, is 0.004 N off here; this is 2e-5).
#[test]
fn a_mean_force_from_an_impact_is_the_impulse_over_the_window() {
    let probes = r#"
  - name: impact
    event: { closes: floor }
  - name: stopping_force
    measure: { contact_force: floor }
    reduce: mean
    from: impact
    to: 1000.5 ms
"#;
    let v = run(&ball(0.0, probes)).unwrap();
    let (g, big_t) = (9.81f64, 1.0005);
    let t1 = (2.0 * 0.9 / g).sqrt();
    let v1 = g * t1;
    let expected = (v1 + g * (big_t - t1)) / (big_t - t1);
    println!("mean force {:.9} N, closed form {expected:.9} N", v[1]);
    assert!((v[1] - expected).abs() < 1e-4, "{} vs {expected}", v[1]);
}

/// With located impacts, a value at a `closes` event is the value at the impact: the ball
/// (e = 0) dropped from 1 m touches at height r = 0.1 m with speed −√(2 g 0.9 m), the
/// speed just before the impact, and rests there. Interpolating between the ends of the
/// step that holds the impact would cut the corner the impact puts in the motion: 0.96 mm
/// high at h = 1 ms. A velocity threshold the impact jumps across is crossed at the impact.
#[test]
fn values_at_a_located_impact_are_the_impact_s() {
    let probes = r#"
  - name: impact
    event: { closes: floor }
  - name: height_at_impact
    measure: { distance: { from: { body: ground }, to: { body: ball }, axis: [0, 0, 1] } }
    at: impact
  - name: speed_at_impact
    measure: { velocity: { body: ball }, axis: [0, 0, 1] }
    at: impact
  - name: stopped
    event: { crosses: -1 m/s, measure: { velocity: { body: ball }, axis: [0, 0, 1] }, direction: up }
  - name: height_at_rest
    measure: { distance: { from: { body: ground }, to: { body: ball }, axis: [0, 0, 1] } }
    at: 900 ms
"#;
    let g = 9.81f64;
    let (t1, v1) = ((2.0 * 0.9 / g).sqrt(), (2.0 * g * 0.9).sqrt());
    for h in ["1 ms", "0.3 ms"] {
        let scene = ball(0.0, probes).replace(
            "integrator: { h: 1 ms, scheme: moreau-jean }",
            &format!("integrator: {{ h: {h}, locate_impacts: true }}"),
        );
        let v = run(&scene).unwrap();
        println!("h = {h}: {v:?}");
        assert!((v[0] - t1).abs() < 1e-8, "impact at {} vs {t1}", v[0]);
        assert!((v[1] - 0.1).abs() < 1e-8, "height at impact {}", v[1]);
        assert!(
            (v[2] + v1).abs() < 1e-6 * v1,
            "speed at impact {} vs −{v1}",
            v[2]
        );
        assert!(
            (v[3] - v[0]).abs() < 1e-12,
            "stopped at {} vs {}",
            v[3],
            v[0]
        );
        // the impact leaves no gap open for the resting ball to hover across
        assert!((v[4] - 0.1).abs() < 1e-8, "height at rest {}", v[4]);
    }
}

#[test]
fn an_event_that_does_not_happen_fails_the_sample_with_a_reason() {
    let probes = r#"
  - name: tenth_impact
    event: { closes: floor, occurrence: 10 }
"#;
    let e = run(&ball(0.5, probes)).unwrap_err();
    assert!(
        e.contains("probe `tenth_impact`") && e.contains("occurrence 10"),
        "{e}"
    );
}

#[test]
fn bad_probe_references_name_the_field_and_line() {
    let e = run(&ball(0.5, "  - name: p\n    event: { closes: flor }\n")).unwrap_err();
    assert!(
        e.contains("`probes[0].event.closes`") && e.contains("unknown contact `flor`"),
        "{e}"
    );
    assert!(e.contains("probe-ball.yaml:18"), "{e}");
    let e = run(&ball(
        0.5,
        "  - name: h\n    measure: { gap: floor }\n  - name: p\n    measure: { gap: floor }\n    reduce: max\n    from: h\n",
    ))
    .unwrap_err();
    assert!(
        e.contains("`probes[1].from`") && e.contains("not an event probe"),
        "{e}"
    );
    let e = run(&ball(
        0.5,
        "  - name: p\n    measure: { gap: floor }\n    reduce: median\n",
    ))
    .unwrap_err();
    assert!(e.contains("unknown reduction `median`"), "{e}");
}

/// A ball dropped from 1 m onto a plastic floor (e = 0) strikes at v = √(2 g 0.9 m) and
/// then rests on it. The largest step force is the impact's impulse m v over one step, so
/// it doubles when h halves; the peak of the force's mean over 20 ms is the impulse over
/// the window plus the weight, m v / w + m g (to O(h/w)), whatever the step.
#[test]
fn a_quasi_static_peak_converges_where_the_step_peak_does_not() {
    let probes = r#"
  - name: step_peak
    measure: { contact_force: floor }
    reduce: max
  - name: quasi_static_peak
    measure: { contact_force: floor }
    reduce: max
    mean_over: 20 ms
"#;
    let (g, w) = (9.81, 0.02);
    let v = (2.0 * g * 0.9f64).sqrt();
    let expected = v / w + g;
    let mut step_peaks = Vec::new();
    for h in ["1 ms", "0.25 ms"] {
        let text = ball(0.0, probes).replace("h: 1 ms", &format!("h: {h}"));
        let s = Subject::from_yaml(&text, "probe-ball.yaml").unwrap();
        let outputs = s.outputs();
        assert!(outputs[0].caution.is_some(), "a step peak is flagged");
        assert!(outputs[1].caution.is_none(), "a quasi-static peak is not");
        let got = run(&text).unwrap();
        assert!(
            (got[1] - expected).abs() < 2e-3 * expected,
            "h = {h}: {} N against {expected} N",
            got[1]
        );
        step_peaks.push(got[0]);
    }
    // the step peak is m v / h: four times larger at a quarter of the step
    assert!(
        (step_peaks[1] / step_peaks[0] - 4.0).abs() < 0.1,
        "{step_peaks:?}"
    );
}

#[test]
fn a_quasi_static_peak_needs_a_window_as_long_as_its_mean() {
    let probes = r#"
  - name: short
    measure: { contact_force: floor }
    reduce: max
    from: 100 ms
    to: 110 ms
    mean_over: 20 ms
"#;
    let e = run(&ball(0.0, probes)).unwrap_err();
    assert!(e.contains("shorter than `mean_over`"), "{e}");
    let probes =
        "  - { name: m, measure: { contact_force: floor }, reduce: mean, mean_over: 2 ms }\n";
    let e = Subject::from_yaml(&ball(0.0, probes), "probe-ball.yaml").unwrap_err();
    assert!(
        e.to_string().contains("goes with `reduce: max` or `min`"),
        "{e}"
    );
}

/// An optional probe whose event does not happen leaves its output empty and says why;
/// the run keeps its other outputs. Without `optional`, the same run fails.
#[test]
fn an_optional_probe_without_its_event_leaves_the_other_outputs() {
    let probes = |optional: bool| {
        format!(
            r#"
  - name: tenth_bounce
    event: {{ closes: floor, occurrence: 10 }}
    optional: {optional}
  - name: first_bounce
    event: {{ closes: floor }}
"#
        )
    };
    let s = Subject::from_yaml(&ball(0.5, &probes(true)), "probe-ball.yaml").unwrap();
    let o = s.run(&[], &[0, 1]);
    assert_eq!(o.error, None);
    assert!(o.outputs[0].is_nan());
    assert!((o.outputs[1] - (2.0 * 0.9 / 9.81f64).sqrt()).abs() < 1e-3);
    assert_eq!(o.missing.len(), 1);
    assert_eq!(o.missing[0].0, 0);
    assert!(o.missing[0].1.contains("occurrence 10"), "{:?}", o.missing);
    // only the selected outputs' absences are reported, by their place in the selection
    let o = s.run(&[], &[1]);
    assert!(o.missing.is_empty() && o.error.is_none());
    let e = run(&ball(0.5, &probes(false))).unwrap_err();
    assert!(e.contains("occurrence 10"), "{e}");
}

/// A curve of the ball's vertical velocity against its height in free fall from 1 m: a
/// grid point's value is the mean velocity while the height is within half a step of it,
/// −s / (t(z − s/2) − t(z + s/2)) with t(z) = √(2 (1 m − z) / g) exactly. The velocity is
/// read at each step's end, so it lags by g h / 2 at most.
#[test]
fn a_curve_is_the_mean_of_y_over_each_cell_of_x() {
    let probes = r#"
  - { name: height, measure: { distance: { from: { body: ground }, to: { body: ball }, axis: [0, 0, 1] } } }
  - { name: speed, measure: { velocity: { body: ball }, axis: [0, 0, 1] } }
  - { name: fall, curve: { x: height, y: speed, grid: "200 mm .. 950 mm step 50 mm" } }
"#;
    let text = ball(0.0, probes).replace("duration: 2 s", "duration: 0.42 s");
    // the curves of a 0.42 s run of the scene `text`
    let curves = |text: &str| {
        let scene = mc_study::scene::Scene::from_yaml(text, "probe-ball.yaml").unwrap();
        let sim = scene.simulation().unwrap();
        let run = mc_study::probe::run::run_probes(
            sim,
            &scene.probes,
            &scene.curves,
            0.42,
            false,
            |_, _, _| {},
        );
        assert!(run.error.is_none());
        run.curves
    };
    let g = 9.81;
    let t = |z: f64| (2.0 * (1.0 - z) / g).sqrt();
    let curve = &curves(&text)[0];
    assert_eq!(curve.len(), 16);
    for (i, v) in curve.iter().enumerate() {
        let z = 0.2 + 0.05 * i as f64;
        let exact = -0.05 / (t(z - 0.025) - t(z + 0.025));
        assert!(
            (v - exact).abs() < g * 1e-3,
            "z = {z}: {v} m/s against {exact} m/s"
        );
    }
    // the ball never goes below its radius: the cells beneath stay empty
    let low = text.replace("200 mm .. 950 mm", "0 mm .. 950 mm");
    let low = &curves(&low)[0];
    assert!(low[0].is_nan() && low[1].is_nan());
}

#[test]
fn bad_curves_name_the_field_and_line() {
    let base =
        "  - { name: z, measure: { gap: floor } }\n  - { name: hit, event: { closes: floor } }\n";
    let cases = [
        (
            "  - { name: c, curve: { x: zz, y: z, grid: \"0 .. 1 step 0.1\" } }\n",
            "`probes[2].curve.x`",
            "`zz` is not a value probe of the scene (value probes: z)",
        ),
        (
            "  - { name: c, curve: { x: z, y: hit, grid: \"0 .. 1 step 0.1\" } }\n",
            "`probes[2].curve.y`",
            "`hit` is an event probe",
        ),
        (
            "  - { name: c, curve: { x: z, y: z, grid: \"0 mm .. 1 s step 1 mm\" } }\n",
            "`probes[2].curve.grid`",
            "the grid's end `1 s` has a unit of a time",
        ),
        (
            "  - { name: c, curve: { x: z, y: z, grid: \"0 mm to 1 mm\" } }\n",
            "`probes[2].curve.grid`",
            "FROM .. TO step STEP",
        ),
        (
            "  - { name: c, curve: { x: z, y: z, grid: \"1 mm .. 0 mm step 1 mm\" } }\n",
            "`probes[2].curve.grid`",
            "must run upward",
        ),
        (
            "  - { name: c, curve: { x: z, y: z, grid: \"0 .. 1 step 0.1\" }, reduce: max }\n",
            "`probes[2].reduce`",
            "a curve takes no `reduce`",
        ),
        (
            "  - { name: c, measure: { gap: floor }, reference: bench.csv }\n",
            "`probes[2].reference`",
            "it goes with `curve`",
        ),
        (
            "  - { name: c, curve: { x: z, y: z, grid: \"0 .. 1 step 0.1\" }, from: nope }\n",
            "`probes[2].from`",
            "`nope` is neither a time",
        ),
    ];
    for (probe, field, message) in cases {
        let e = run(&ball(0.5, &format!("{base}{probe}"))).unwrap_err();
        assert!(e.contains(field) && e.contains(message), "{e}");
        assert!(e.contains("probe-ball.yaml:19"), "{e}");
    }
}
