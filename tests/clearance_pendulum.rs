//! The frictionless clearance pendulum (bar 1 m, 1 kg, c = 10 mm, e = 0.5, journal centred,
//! released horizontal) at steps from fine to far coarser than its clearance: no accepted
//! state penetrates or gains energy, plain Moreau–Jean's drift into the concave bore wall
//! is that of its impacts, and a planar run stays in its plane. With friction in a tight
//! journal, a coarse step dissipates what a fine one does.

mod common;

#[path = "harness/extremes.rs"]
mod extremes;
use mc_study::integrator::{Scheme, Simulation};

/// The pendulum of the coarse-step extremes cells (`extremes::coarse_clearance_pendulum`),
/// swinging about the y axis, in the xz plane if `planar`. Its flange radius is left to
/// its default, which must clear the bore's radius plus the clearance (20 mm here, where
/// 1.5 R_J is only 15 mm).
fn pendulum(scheme: Scheme, h: f64, planar: bool) -> Simulation {
    let mut scene = extremes::coarse_clearance_pendulum(h, planar, 2.0).scene;
    scene.params.scheme = scheme;
    common::simulation(scene)
}

/// Runs to `t` and returns the largest rise of the total energy above its start and the
/// largest penetration at the accepted step ends.
fn rise_and_penetration(sim: &mut Simulation, t: f64) -> (f64, f64) {
    let e0 = sim.energy();
    let mut rise: f64 = 0.0;
    sim.run_until(t, |s, _| rise = rise.max(s.energy() - e0))
        .unwrap_or_else(|e| panic!("{e}"));
    (rise, sim.stats.max_penetration)
}

/// Runs to `t` and returns the largest rise of the total energy above its start and the
/// largest impulse any contact took in a step.
fn rise_and_largest_impulse(sim: &mut Simulation, t: f64) -> (f64, f64) {
    let e0 = sim.energy();
    let (mut rise, mut largest): (f64, f64) = (0.0, 0.0);
    sim.run_until(t, |s, _| {
        rise = rise.max(s.energy() - e0);
        for p in s.impulses() {
            largest = largest.max(p.norm());
        }
    })
    .unwrap_or_else(|e| panic!("{e}"));
    (rise, largest)
}

/// The largest rise of the energy above its start over `t` of the same bar on an ideal
/// joint at step h: what the θ-scheme's own error on the smooth swing gives.
fn ideal_rise(h: f64, t: f64) -> f64 {
    let mut sim = common::simulation(extremes::ideal_pendulum(h, t, u64::MAX).scene);
    rise_and_penetration(&mut sim, t).0
}

/// A frictionless joint with e ≤ 1 can only lose energy. Under combined projection, in
/// its plane, the pendulum gains none at h = 0.02, 0.01 and 1e-3 (it gained 0.08 J at 0.01
/// when restitution acted on the journal sliding around its bore), and no accepted state
/// penetrates. At h = 0.05 and 0.03 (five and eight steps to a quarter swing) it gains less
/// than the same bar on an ideal joint does from the θ-scheme's error on the smooth swing
/// alone (measured: 0.0056 J against 0.018 J at 0.05, 0.0031 J against 0.0072 J at 0.03):
/// the contact adds no energy of its own. At 0.05 it runs to its end (it aborted, "journal
/// left its bore", on a trial step): the steps whose trial leaves the bore or whose
/// projection fails are taken in halves.
#[test]
fn coarse_steps_neither_abort_nor_gain_energy() {
    for h in [0.05, 0.03, 0.02, 0.01, 1e-3] {
        let mut sim = pendulum(Scheme::CombinedProjection, h, true);
        let (rise, penetration) = rise_and_penetration(&mut sim, 2.0);
        let allowed = if h >= 0.03 { ideal_rise(h, 2.0) } else { 1e-12 };
        assert!(
            rise < allowed,
            "h = {h}: energy rose by {rise:.3e} J (allowed {allowed:.3e} J)"
        );
        assert!(
            penetration < 1e-9,
            "h = {h}: penetration {penetration:.3e} m"
        );
        if h == 0.05 {
            assert!(sim.stats.halved_steps > 0, "h = {h}: no step was halved");
        }
    }
}

/// In space, at coarse steps, the bar's roll brings its journal against both flanges at
/// once (tilted in its bore, pressed on one and held at the other by the last step's
/// impulse). Holding every closed contact shut as equalities then admits either no poses
/// near the trial or only distant ones: at h = 0.02 a projection threw the bar nine times
/// the step's own motion (the bar gained 0.037 J, penetrated 6e-5 m and left its bore at
/// 2.48 s), and at h = 0.005 a journal left its bore at 2.17 s. A projection that lands
/// farther from the trial than the start of the step is refused (the start is admissible,
/// so the nearest poses are nearer), and one that fails is redone with every active
/// contact free to open.
#[test]
fn a_journal_jammed_between_its_flanges_stays_in_its_bore_without_gaining_energy() {
    for h in [0.02, 0.005] {
        let mut sim = pendulum(Scheme::CombinedProjection, h, false);
        let (rise, penetration) = rise_and_penetration(&mut sim, 5.0);
        assert!(rise < 1e-12, "h = {h}: energy rose by {rise:.3e} J");
        assert!(
            penetration < 1e-9,
            "h = {h}: penetration {penetration:.3e} m"
        );
        assert_eq!(sim.stats.projection_failures, 0, "h = {h}");
    }
}

/// A step in which one impact knocks another contact shut is split at the first impact,
/// whether or not impacts are located; the part before the impact is a trial like any
/// other. Without restitution, in space, at h = 0.03, such a part carried the journal out
/// of its bore at 0.66 s and stopped the run, where the whole step would have been taken
/// in halves: the part's failure now halves the step.
#[test]
fn a_part_before_an_impact_that_leaves_the_bore_is_taken_in_halves() {
    let mut scene = extremes::coarse_clearance_pendulum(0.03, false, 5.0).scene;
    scene.set_parameter("joints.pivot.e", 0.0).unwrap();
    let mut sim = common::simulation(scene);
    sim.run_until(5.0, |_, _| {})
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(sim.stats.impact_splits > 0);
    assert!(
        sim.stats.max_penetration < 1e-9,
        "{:e}",
        sim.stats.max_penetration
    );
}

/// With located impacts, a step is taken in parts: before the impact, the impact, the
/// rest. Two flanges pressing on a jammed journal from both sides can carry any equal and
/// opposite pair of impulses, which the velocity problem does not see; warm-started from
/// the step's sum of its parts, that pair doubled at every split step, to 6e11 N·s, and
/// its round-off gave the bar 2.3 J before the state turned non-finite at 3.5 s (h = 0.03,
/// in space). The warm start is now the last velocity problem's own impulse.
#[test]
fn located_impacts_on_a_jammed_journal_keep_its_impulses_bounded() {
    let mut scene = extremes::coarse_clearance_pendulum(0.03, false, 5.0).scene;
    scene.params.locate_impacts = true;
    let mut sim = common::simulation(scene);
    let (rise, largest) = rise_and_largest_impulse(&mut sim, 5.0);
    assert!(largest < 100.0, "an impulse of {largest:.3e} N·s");
    assert!(rise < 1e-12, "energy rose by {rise:.3e} J");
    assert!(sim.stats.impact_splits > 0);
    assert!(
        sim.stats.max_penetration < 1e-9,
        "{:e}",
        sim.stats.max_penetration
    );
}

/// A step that carries the journal across its 0.1 mm axial play leaves one flange and
/// strikes the other, whose rim points face those of the first on the same lines. Both in
/// the velocity problem, their conditions held at one axial velocity only, and round-off
/// drove the solver along the pair: over 5 s in space the largest impulse was 113 N·s at
/// h = 0.01 and 37 N·s at 0.03 (e = 0.5), 1e7 N·s at 0.03 with e = 0, 3.9e7 N·s with
/// located impacts, where the bar's weight over a step is 0.3 N·s; the bar gained 0.31 J
/// at 0.03. The flange the step leaves now stays out of the velocity problem while the one
/// it strikes holds.
#[test]
fn a_journal_crossing_its_axial_play_is_not_squeezed_between_its_flanges() {
    for located in [false, true] {
        for e in [0.5, 0.0] {
            for h in [0.03, 0.02, 0.01] {
                let mut scene = extremes::coarse_clearance_pendulum(h, false, 5.0).scene;
                scene.set_parameter("joints.pivot.e", e).unwrap();
                scene.params.locate_impacts = located;
                let mut sim = common::simulation(scene);
                let (rise, largest) = rise_and_largest_impulse(&mut sim, 5.0);
                let case = format!("located {located}, e = {e}, h = {h}");
                assert!(largest < 5.0, "{case}: an impulse of {largest:.3e} N·s");
                // at 0.03 no more than the θ-scheme's error on the smooth swing gives
                let allowed = if h == 0.03 { ideal_rise(h, 5.0) } else { 1e-12 };
                assert!(rise < allowed, "{case}: energy rose by {rise:.3e} J");
                assert!(sim.stats.max_penetration < 1e-9, "{case}");
            }
        }
    }
}

/// Plain Moreau–Jean keeps no position constraint: its penetration is the depth its impacts
/// reach within their steps, O(h). Sliding along the concave bore adds none of its own: a
/// contact that stays closed takes its impulse on the rows at mid-step and its velocity
/// condition on the rows at the step's end, so the curved wall does not pull it in.
/// Siconos' Moreau–Jean penetrates 3.2e-5 m at h = 1e-4 (on start-of-step rows ours sank
/// 7.1e-4 m at 1e-4 and 7.6e-3 m at 1e-3).
#[test]
fn plain_moreau_jean_sinks_into_the_bore_only_by_its_impacts() {
    let mut depth = Vec::new();
    for h in [1e-3, 1e-4] {
        let mut sim = pendulum(Scheme::MoreauJean, h, true);
        let (rise, penetration) = rise_and_penetration(&mut sim, 1.0);
        assert!(rise < 1e-12, "h = {h}: energy rose by {rise:.3e} J");
        depth.push(penetration);
    }
    // 1.20e-4 and 3.22e-5 m measured
    assert!(depth[0] < 1.5e-4, "h = 1e-3: {:.3e} m", depth[0]);
    assert!(depth[1] < 4e-5, "h = 1e-4: {:.3e} m", depth[1]);
    assert!(depth[1] < depth[0] / 3.0, "not O(h): {depth:?}");
}

/// Swinging in its plane, the bar is unstable about its long axis (its roll grows from
/// round-off, about e^{100 t} here, as in any exact spatial model: the journal may tilt in
/// its bore, up to atan(2c / L_B) = 45° here): in space the run must end inside the bore
/// all the same. `plane: xz` holds the
/// bar in the plane of the swing: not a trace of out-of-plane motion, and the swing of the
/// spatial bar before its roll grows.
#[test]
fn a_planar_swing_stays_in_its_plane() {
    let mut planar = pendulum(Scheme::CombinedProjection, 1e-3, true);
    let mut out_of_plane: f64 = 0.0;
    planar
        .run_until(2.0, |s, _| {
            let v = &s.state.v;
            out_of_plane = out_of_plane
                .max(s.state.poses[0].x.y.abs())
                .max(v[1].abs())
                .max(v[3].abs())
                .max(v[5].abs());
        })
        .unwrap();
    assert_eq!(out_of_plane, 0.0);
    // at 0.3 s, before the spatial bar's roll has grown: in space the journal's wall contact
    // keeps its start-of-step rows (first order: 1.2e-4, 1.4e-5 and 1.5e-6 m off at
    // h = 1e-3, 1e-4 and 1e-5), in the plane its mid-step and end rows (8e-6 m at 1e-3,
    // 1.5e-7 m at 1e-4); both converge to the same swing
    let at = |planar: bool, h: f64| {
        let mut sim = pendulum(Scheme::CombinedProjection, h, planar);
        sim.run_until(0.3, |_, _| {}).unwrap();
        sim.state.poses[0].x
    };
    let (a, b) = (at(false, 1e-5), at(true, 1e-3));
    assert!((a - b).norm() < 2e-5, "spatial {a:?}, planar {b:?}");
    let c = at(true, 1e-4);
    assert!((a - c).norm() < 3e-6, "spatial {a:?}, planar {c:?}");
    // the spatial run goes on to its end, rolling, without leaving its bore
    pendulum(Scheme::CombinedProjection, 1e-3, false)
        .run_until(5.0, |_, _| {})
        .unwrap_or_else(|e| panic!("{e}"));
}

/// A journal wedged across its bore (c = 70 µm, μ = 5 and 8 above L_B / 2R_J = 1, h = 1e-4,
/// the bar of `studies/pendulum-clearance`) makes its contact problem nearly singular.
/// With restitution, Newton's law then asks for rebounds that only impulses far beyond
/// what the step calls for can give, and they gave the bar energy: 916 J in one step, with
/// impulses of 1.2e5 N·s. Whether a run met such a step depended on rounding: 18 of these
/// 36 runs, at clearances 1e-7 apart, gained from 0.78 to 919 J, and a change at the last
/// bits of the ring's closest-point iteration turned the run at μ = 5, e = 0.5 and 70 µm
/// from none into a 159 J gain. Such steps now take their impacts plastic
/// (`RunStats::plastic_steps`), and no run gains energy.
#[test]
fn a_wedged_journal_gains_no_energy_whatever_its_rounding() {
    let mut plastic = 0;
    for mu in [5.0, 8.0] {
        for e in [0.5, 0.9] {
            for k in -4..=4 {
                let c = 7e-5 * (1.0 + f64::from(k) * 1e-7);
                let case = extremes::clearance_pendulum(c, 1e-4, mu, e, 0.45, u64::MAX);
                let mut sim = common::simulation(case.scene);
                let (rise, penetration) = rise_and_penetration(&mut sim, 0.45);
                let label = format!("μ = {mu}, e = {e}, c = 70 µm × (1 + {k}e-7)");
                assert!(
                    sim.stats.steps >= 4500,
                    "{label}: {} steps",
                    sim.stats.steps
                );
                assert!(rise < 1e-9, "{label}: energy rose by {rise:.3e} J");
                assert!(
                    penetration < 1e-9,
                    "{label}: penetration {penetration:.3e} m"
                );
                plastic += sim.stats.plastic_steps;
            }
        }
    }
    assert!(plastic > 0, "no step jammed");
}

/// Friction in a tight journal (c = 1 µm, μ = 0.1, e = 0) takes 0.025 J of the bar's
/// 4.9 J in its first second at h = 1e-4, and must take as much at h = 1e-3, where each
/// step carries the journal around its bore by a hundred clearances. It took 3.3 J: the
/// steps that threw the journal across its clearance put the ring's guards in the
/// velocity problem beside its closest point on mid-step rows, and the solver returned
/// large, nearly cancelling normal impulses (204 N·s on the ring where the step needed
/// 0.01), whose friction braked the bar.
#[test]
fn friction_in_a_tight_journal_takes_as_much_energy_at_coarse_steps_as_at_fine_ones() {
    let loss = |h: f64| {
        let case = extremes::clearance_pendulum(1e-6, h, 0.1, 0.0, 1.0, u64::MAX);
        let mut sim = common::simulation(case.scene);
        let e0 = sim.energy();
        sim.run_until(1.0, |_, _| {})
            .unwrap_or_else(|e| panic!("{e}"));
        e0 - sim.energy()
    };
    let fine = loss(1e-4);
    assert!((0.02..0.03).contains(&fine), "lost {fine:.4} J at h = 1e-4");
    let coarse = loss(1e-3);
    assert!(
        (coarse - fine).abs() < 0.1 * fine,
        "lost {coarse:.4} J at h = 1e-3, {fine:.4} J at h = 1e-4"
    );
}

/// Plain Moreau–Jean does not project: at a coarse step (5 ms) the bundled pendulum's
/// journal sinks into its 70 µm bore, by 8.7e-4 m over the run's second, and the sample
/// says so (`suspect`, naming the clearance). At the bundled fine step, with the combined
/// scheme the scene uses, it does not. (The scene has no probes: one at its end makes the
/// run go to its end.)
#[test]
fn plain_moreau_jean_sinking_into_a_clearance_is_suspect() {
    let text = std::fs::read_to_string("studies/pendulum-clearance/scene.yaml").unwrap();
    let run = |scheme: &str, h: &str| {
        // a probe at the run's end, so that the run goes to its end
        let yaml = text
            .replace("scheme: combined-projection", &format!("scheme: {scheme}"))
            .replace("h: 0.1 ms", &format!("h: {h}"))
            .replace(
                "record:\n  every: 10",
                "probes:\n  - { name: angle, measure: { angle: pivot } }",
            );
        let subject = mc_study::study::Subject::from_yaml(&yaml, "pendulum-clearance").unwrap();
        let o = subject.run(&[], &[]);
        assert!(o.error.is_none(), "{scheme} at {h}: {:?}", o.error);
        println!(
            "{scheme} at {h}: penetration {:.3e} m, {:?}",
            o.diagnostics.max_penetration, o.suspect
        );
        o
    };
    let coarse = run("moreau-jean", "5 ms");
    assert!(coarse.diagnostics.max_penetration > 7e-5);
    let why = coarse.suspect.expect("a coarse plain run is suspect");
    assert!(why.contains("smallest clearance (7.000e-5 m)"), "{why}");
    let fine = run("combined-projection", "0.1 ms");
    assert_eq!(fine.suspect, None);
}

/// The bundled pendulum (70 µm joint) pushed along its joint's axis by 3 N for 0.3 s and
/// then released: at h = 5, 10 and 20 ms a step carries the journal across its ring, and
/// the ring's closest point and a guard on the far side both push (impulse pairs of up to
/// 2.1e3 N·s at 10 ms and 4.3e3 N·s at 20 ms, against the 5.6 N·s a fine step's largest
/// takes; the bar then loses 0.20 and 0.59 J after the release, against 0.04 J at 1 ms).
/// Such a sample is suspect and says why; at 1 and 2 ms, where the run is clean, it is not.
#[test]
fn a_journal_squeezed_across_its_ring_by_a_coarse_step_is_suspect() {
    let text = std::fs::read_to_string("studies/pendulum-clearance/scene.yaml").unwrap();
    let run = |h: &str| {
        let yaml = text.replace("h: 0.1 ms", &format!("h: {h}")).replace(
            "record:\n  every: 10",
            "forces:\n  - load: { body: bar, force_table: [[0, 0, 3 N, 0], [0.3 s, 0, 3 N, 0], [0.30001 s, 0, 0, 0]] }\nprobes:\n  - { name: angle, measure: { angle: pivot } }",
        );
        let subject = mc_study::study::Subject::from_yaml(&yaml, "pushed pendulum").unwrap();
        let o = subject.run(&[], &[]);
        assert!(o.error.is_none(), "{h}: {:?}", o.error);
        o.suspect
    };
    for h in ["1 ms", "2 ms"] {
        assert_eq!(run(h), None, "{h}");
    }
    for h in ["10 ms", "20 ms"] {
        let why = run(h).unwrap_or_else(|| panic!("{h}: squeezed, unflagged"));
        assert!(why.contains("squeezed across its ring"), "{h}: {why}");
    }
}
