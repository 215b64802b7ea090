"""The Python package against the command line: the same runs, bit for bit.

MC_STUDY_BIN names the `mc-study` binary to compare with (tests/python.rs sets it).
"""

import os
import subprocess
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

import mc_study as mc

ROOT = Path(__file__).resolve().parents[2]
STUDIES = ROOT / "studies"
BIN = os.environ.get("MC_STUDY_BIN", "mc-study")


def cli(*args):
    done = subprocess.run([BIN, *map(str, args)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return done.stdout


def bits(a):
    return np.asarray(a, dtype="<f8").view("<u8")


def test_simulate_equals_the_cli_bit_for_bit(tmp_path):
    scene = STUDIES / "bouncing-ball" / "scene.yaml"
    out = tmp_path / "cli.parquet"
    printed = cli("simulate", scene, "--set", "contacts.floor.e=0.85", "--out", out)
    run = mc.simulate(mc.Scene.load(scene).set("contacts.floor.e", 0.85))
    assert run.error is None
    cli_table = pq.read_table(out)
    assert cli_table.column_names == run.trajectory.column_names
    for name in cli_table.column_names:
        assert np.array_equal(bits(cli_table[name]), bits(run.trajectory[name])), name
    # the probes as the CLI prints them (10 significant digits) are the package's values
    for name, value in run.probes.items():
        line = next(l for l in printed.splitlines() if l.split() and l.split()[0] == name)
        assert float(line.split()[1]) == float(f"{value:.9e}"), (name, line, value)
    arrays = run.arrays()
    assert arrays["t"][0] == 0.0 and arrays["t"][-1] == pytest.approx(10.0)


def test_units_are_accepted_as_strings_and_checked():
    scene = mc.Scene.load(STUDIES / "bouncing-ball" / "scene.yaml")
    a = mc.simulate(scene.set("bodies.ball.position.z", "1.2 m")).probes
    b = mc.simulate(mc.Scene.load(STUDIES / "bouncing-ball" / "scene.yaml").set("bodies.ball.position.z", 1.2)).probes
    assert a == b
    with pytest.raises(mc.McStudyError, match="bodies.ball.position.z"):
        scene.set("bodies.ball.position.z", "2 s")


def test_errors_carry_the_engines_messages():
    with pytest.raises(mc.McStudyError, match=r"mine\.yaml.*line 3"):
        mc.Scene.from_yaml("name: x\nduration: 1 s\nbodies: 7\n", "mine.yaml")
    scene = mc.Scene.load(STUDIES / "bouncing-ball" / "scene.yaml")
    with pytest.raises(mc.McStudyError, match="unknown parameter path"):
        scene.set("contacts.floor.stiffness", 1.0)
    with pytest.raises(mc.McStudyError, match="n × 1"):
        mc.evaluate(scene, ["contacts.floor.e"], np.zeros((3, 2)))


def test_study_run_equals_the_cli_results(tmp_path):
    study = STUDIES / "bouncing-ball" / "study.yaml"
    cli("run", study, "--samples", 24, "--quiet", "--out", tmp_path / "cli")
    table = mc.Study.load(study, samples=24).run(out=tmp_path / "py", threads=2)
    expected = pq.read_table(tmp_path / "cli" / "results.parquet")
    assert table.column_names == expected.column_names
    for name in expected.column_names:
        if name == "wall_ms":
            continue
        a, b = expected[name], table[name]
        if str(a.type) == "double":
            assert np.array_equal(bits(a), bits(b)), name
        else:
            assert a.to_pylist() == b.to_pylist(), name
    summary = mc.Study.load(study, samples=24).summary(tmp_path / "py")
    assert summary == mc.Study.load(study).summary(tmp_path / "cli")


def test_evaluate_is_the_same_at_any_thread_count_and_flags_failed_rows():
    scene = mc.Scene.load(STUDIES / "bouncing-ball" / "scene.yaml")
    paths = ["contacts.floor.e", "bodies.ball.position.z"]
    X = np.column_stack([np.linspace(0.5, 0.95, 8), np.linspace(0.8, 1.2, 8)])
    X[5, 0] = -1.0  # a restitution the scene refuses
    one = mc.evaluate(scene, paths, X, threads=1)
    two = mc.evaluate(scene, paths, X, threads=2)
    assert one.outputs == scene.outputs()
    assert np.array_equal(bits(one.values), bits(two.values))
    assert one.errors == two.errors
    assert np.isnan(one.values[5]).all() and "contacts.floor.e" in one.errors[5]
    ok = [i for i in range(8) if i != 5]
    assert all(one.errors[i] is None for i in ok)
    # closed form of the first impact: drop gap z0 − 0.1 m under 9.81 m/s² (the probe
    # locates the event within its step to about 1e-6 s)
    t_exact = np.sqrt(2 * (X[ok, 1] - 0.1) / 9.81)
    assert np.allclose(one.values[ok, 0], t_exact, rtol=0, atol=5e-6)


def test_evaluate_of_a_study_gives_its_outputs_as_its_runner_does(tmp_path):
    study = mc.Study.load(STUDIES / "ishigami" / "study.yaml", samples=64)
    table = study.run(out=tmp_path / "ishigami")
    X = np.column_stack([table[p].to_numpy() for p in study.parameters()])
    values = mc.evaluate(study, study.parameters(), X).values
    for k, name in enumerate(study.outputs()):
        assert np.array_equal(bits(values[:, k]), bits(table[name])), name


INTERRUPTED = """
import sys, time, numpy as np, mc_study as mc
what, out = sys.argv[1], sys.argv[2]
try:
    print("ready", flush=True)
    if what == "run":
        mc.Study.load({study!r}, samples=100000).run(out=out, threads=2)
    else:
        scene = mc.Scene.load({scene!r})
        mc.evaluate(scene, ["bodies.ball.position.z"], np.full((100000, 1), 1.0), threads=2)
except KeyboardInterrupt:
    print("interrupted", time.monotonic(), flush=True)
    sys.exit(3)
"""


@pytest.mark.parametrize("what", ["run", "evaluate"])
def test_ctrl_c_stops_cleanly_and_keeps_the_finished_samples(tmp_path, what):
    import signal
    import sys
    import time

    script = INTERRUPTED.format(
        study=str(STUDIES / "bouncing-ball" / "study.yaml"),
        scene=str(STUDIES / "bouncing-ball" / "scene.yaml"),
    )
    out = tmp_path / "out"
    # A runner that starts the tests in the background (a shell without job control, some
    # CI services) leaves SIGINT ignored, the child inherits that and Python then installs
    # no KeyboardInterrupt handler: give the child the default disposition.
    child = subprocess.Popen(
        [sys.executable, "-c", script, what, str(out)],
        stdout=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    # interrupt the work, not the imports: on a loaded machine they alone can take seconds
    assert child.stdout.readline() == "ready\n"
    time.sleep(2.0)
    sent = time.monotonic()
    child.send_signal(signal.SIGINT)
    stdout, _ = child.communicate(timeout=60)
    assert child.returncode == 3, stdout
    stopped = float(stdout.split()[1])
    assert stopped - sent < 2.0, f"took {stopped - sent:.2f} s to stop"
    if what == "run":
        parts = list((out / "parts").glob("*.parquet"))
        saved = sum(pq.read_metadata(p).num_rows for p in parts)
        assert saved > 0, "no finished sample was kept"
        # resuming skips what was saved: the ids stored are distinct and in range
        ids = np.concatenate([pq.read_table(p)["sample_id"].to_numpy() for p in parts])
        assert len(set(ids.tolist())) == saved and ids.max() < 100000
