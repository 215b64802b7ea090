"""Morris screening of the circuit breaker's seven joint clearances with SALib.

SALib draws r Morris trajectories over the clearances (mean ± 2σ of the study's
distributions, 0.035–0.105 mm), `mc_study.evaluate` runs the (d + 1) r mechanisms in
parallel, and SALib's μ* ranks the clearances per output. The clearance that matters
most for each output is compared with the bundled 512-sample study's strongest input
(its SRC² ranking, studies/c60/README.md) where that study finds one input dominant.

    python examples/salib_morris_c60.py [r]      (r = 4 by default: 32 simulations)
"""

import sys
from pathlib import Path

import numpy as np
from SALib.analyze import morris as analyze
from SALib.sample import morris as sample

import mc_study as mc

HERE = Path(__file__).resolve().parent
STUDY = HERE.parent.parent / "studies" / "c60" / "study.yaml"

# the strongest input of the bundled study where it dominates (|ρ| ≥ 0.74)
BUNDLED_TOP = {
    "FC1_contact_force": "joints.J3.clearance",
    "FC2_needle_pin_x": "joints.J5.clearance",
    "FC3_needle_pin_y": "joints.J5.clearance",
    "FC4_needle_lamage_x": "joints.J5.clearance",
    "FC5_needle_lamage_y": "joints.J5.clearance",
    "FC6_bar_plunger_x": "joints.J6.clearance",
    "strike_time": "joints.J6.clearance",
    "trip_time": "joints.J5.clearance",
    "contact_opening_time": "joints.J5.clearance",
}


def main(r: int) -> None:
    study = mc.Study.load(STUDY)
    paths = study.parameters()
    problem = {"num_vars": len(paths), "names": paths, "bounds": [[0.035e-3, 0.105e-3]] * len(paths)}
    X = sample.sample(problem, N=r, num_levels=4, seed=2026)
    result = mc.evaluate(study, paths, X)
    failed = [e for e in result.errors if e is not None]
    assert not failed, failed
    print(f"{len(X)} simulations; μ* (scaled by σ of the output over the design) per clearance")
    print(f"{'output':22} " + " ".join(p.split('.')[1] for p in paths) + "   top (Morris) / top (bundled study)")
    agree = 0
    for k, name in enumerate(result.outputs):
        y = result.values[:, k]
        si = analyze.analyze(problem, X, y, num_levels=4, seed=2026)
        mu_star = np.asarray(si["mu_star"]) / (np.std(y) or 1.0)
        top = paths[int(np.argmax(mu_star))]
        expected = BUNDLED_TOP.get(name)
        mark = "" if expected is None else ("  ✓" if top == expected else f"  ✗ ({expected})")
        print(f"{name:22} " + " ".join(f"{m:4.2f}" for m in mu_star) + f"   {top.split('.')[1]}{mark}")
        if expected is not None:
            assert top == expected, (name, top, expected)
            agree += 1
    print(f"Morris names the bundled study's strongest clearance for all {agree} outputs that have one")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 4)
