"""Time per step of MuJoCo on the scenes that `cargo bench --bench step` times, for a
side-by-side comparison on one machine (docs/fidelity.md, "What a step costs").

Each case mirrors a bundled scene at its step h = 1 ms and runs as long as the bench runs
it: the bouncing ball (10 s), the block on the 20° incline with friction 0.5 (3 s), the
free rigid body (10 s) and the pendulum on a revolute joint (2 s). MuJoCo runs with its
defaults (Euler, Newton solver) and steps in C (`mj_step(..., nstep=N)`), so Python adds
nothing per step. Its contacts are soft, so its trajectories differ from ours; what is
compared is the cost of a step.

Run: python3 -m pip install mujoco && python3 benches/peers/mujoco_step.py
"""

import statistics
import time

import mujoco

H = 'timestep="0.001" gravity="0 0 -9.81"'


def sliding_down_the_slope(data):
    """The incline block's start: 2 m/s down the 20° slope."""
    data.qvel[0:3] = [1.8793852415718169, 0.0, -0.6840402866513374]


def spun_about_the_intermediate_axis(data):
    """The free body's start: body-frame angular velocity (0.01, 2, 0.01) rad/s."""
    data.qvel[3:6] = [0.01, 2.0, 0.01]

CASES = {
    # studies/bouncing-ball: a 1 kg sphere of radius 0.1 m dropped from 1 m onto a plane
    "step/bouncing_ball": (
        f"""<mujoco><option {H}/><worldbody><geom type="plane" size="50 50 0.1"/>
        <body pos="0 0 1"><freejoint/><geom type="sphere" size="0.1" mass="1"/></body>
        </worldbody></mujoco>""",
        10.0,
        None,
    ),
    # studies/incline-block: a 1 kg box 0.2 × 0.2 × 0.05 m on a 20° slope, 2 m/s down it
    "step/box_4_corners_friction": (
        f"""<mujoco><option {H}/><worldbody>
        <geom type="plane" size="50 50 0.1" euler="0 20 0" friction="0.5 0 0"/>
        <body pos="0.008550503583141718 0 0.023492315519647713" euler="0 20 0"><freejoint/>
        <geom type="box" size="0.1 0.1 0.025" mass="1" friction="0.5 0 0"/></body>
        </worldbody></mujoco>""",
        3.0,
        sliding_down_the_slope,
    ),
    # studies/free-body: inertia diag(1, 2, 3), spun about the intermediate axis, no gravity
    "step/free_rigid_body": (
        """<mujoco><option timestep="0.001" gravity="0 0 0"/><worldbody>
        <body><freejoint/><inertial pos="0 0 0" mass="1" diaginertia="1 2 3"/></body>
        </worldbody></mujoco>""",
        10.0,
        spun_about_the_intermediate_axis,
    ),
    # studies/pendulum: a 1 kg bar 1 m × 20 mm × 20 mm pivoting about y at its end
    "scheme/pendulum": (
        f"""<mujoco><option {H}/><worldbody><body><joint type="hinge" axis="0 1 0"/>
        <geom type="box" size="0.5 0.01 0.01" pos="0.5 0 0" mass="1" contype="0"
        conaffinity="0"/></body></worldbody></mujoco>""",
        2.0,
        None,
    ),
}


def per_step(xml, duration, start, runs=15):
    """Median over `runs` runs of the wall time per step (µs), with its range."""
    model = mujoco.MjModel.from_xml_string(xml)
    steps = round(duration / model.opt.timestep)
    times = []
    for _ in range(runs):
        data = mujoco.MjData(model)
        if start:
            start(data)
        t0 = time.perf_counter()
        mujoco.mj_step(model, data, nstep=steps)
        times.append((time.perf_counter() - t0) / steps * 1e6)
    return statistics.median(times), min(times), max(times)


if __name__ == "__main__":
    print(f"MuJoCo {mujoco.__version__}, µs per step (median of 15 runs, range)")
    for name, (xml, duration, start) in CASES.items():
        med, lo, hi = per_step(xml, duration, start)
        print(f"{name:30s} {med:7.3f}  ({lo:.3f}–{hi:.3f})")
