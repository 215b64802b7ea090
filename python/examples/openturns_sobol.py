"""Sobol' indices of the bouncing ball with OpenTURNS, on mc-study's own Saltelli design.

The scene is wrapped as an OpenTURNS function whose sample evaluation calls
`mc_study.evaluate` (all cores, the GIL released). The design is the one `mc-study run`
stored in results.parquet, put in OpenTURNS' block order [A; B; E_1; ...; E_d], and
OpenTURNS' Saltelli estimator is compared with `mc-study report`'s indices: the two must
agree within their bootstrap intervals.

    python examples/openturns_sobol.py [OUT]     (MC_STUDY_BIN names the mc-study binary)
"""

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import openturns as ot

import mc_study as mc

HERE = Path(__file__).resolve().parent
BIN = os.environ.get("MC_STUDY_BIN", "mc-study")


def main(out: Path) -> None:
    study = mc.Study.load(HERE / "bouncing-ball-saltelli.yaml")
    table = study.run(out=out)
    paths, outputs = study.parameters(), study.outputs()
    d, n = len(paths), table.num_rows // (len(paths) + 2)
    # mc-study stores each base row as [A, B, AB_1, ..., AB_d]; OpenTURNS wants the blocks
    rows = np.column_stack([table[p].to_numpy() for p in paths]).reshape(n, d + 2, d)
    design = ot.Sample(rows.transpose(1, 0, 2).reshape(-1, d))

    scene = study.scene()

    def func_sample(x):
        return mc.evaluate(scene, paths, np.asarray(x)).values[:, [scene.outputs().index(o) for o in outputs]]

    model = ot.PythonFunction(d, len(outputs), func_sample=func_sample)
    y = model(design)

    subprocess.run([BIN, "report", str(out)], check=True, capture_output=True)
    report = json.loads((out / "report" / "sensitivity.json").read_text())
    print(f"{'output':26} {'input':24} {'kind':6} {'OpenTURNS':>10} {'mc-study':>10}  mc-study 95 % interval")
    for k, name in enumerate(outputs):
        algo = ot.SaltelliSensitivityAlgorithm(design, y.getMarginal(k), n)
        ours = next(s for s in report if s["output"] == name)["sobol"]
        for kind, theirs, interval, estimates in [
            ("first", algo.getFirstOrderIndices(), algo.getFirstOrderIndicesInterval(), ours["first"]),
            ("total", algo.getTotalOrderIndices(), algo.getTotalOrderIndicesInterval(), ours["total"]),
        ]:
            for j, path in enumerate(paths):
                lo, hi = estimates[j]["ci95"]
                t_lo, t_hi = interval.getLowerBound()[j], interval.getUpperBound()[j]
                print(f"{name:26} {path:24} {kind:6} {theirs[j]:10.4f} {estimates[j]['value']:10.4f}  [{lo:.4f}, {hi:.4f}]")
                # the two estimates agree within their bootstrap intervals (they overlap)
                assert t_lo <= hi and lo <= t_hi, (name, path, kind, theirs[j], (t_lo, t_hi), (lo, hi))
    print("OpenTURNS and mc-study agree within their bootstrap intervals")


if __name__ == "__main__":
    if len(sys.argv) > 1:
        main(Path(sys.argv[1]))
    else:
        with tempfile.TemporaryDirectory() as tmp:
            main(Path(tmp) / "out")
