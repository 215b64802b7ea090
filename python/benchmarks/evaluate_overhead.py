"""The cost `evaluate` adds per row over the Rust call it makes, and its speed-up from 1 to
2 threads, on the Ishigami function scene (a row costs about a microsecond in Rust, so
the overhead shows). Run from the repository root, with the package installed:

    cargo build --release --example evaluate_rows
    python python/benchmarks/evaluate_overhead.py [n]
"""

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import mc_study as mc

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "studies" / "ishigami" / "scene.yaml"
PATHS = ["inputs.x1", "inputs.x2", "inputs.x3"]


def best_of(f, repeat=5):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        f()
        times.append(time.perf_counter() - start)
    return sorted(times)[len(times) // 2]  # the median


def main(n: int) -> None:
    rng = np.random.default_rng(1)
    X = rng.uniform(-np.pi, np.pi, size=(n, 3))
    scene = mc.Scene.load(SCENE)
    with tempfile.NamedTemporaryFile(suffix=".bin") as f:
        f.write(X.astype("<f8").tobytes())
        f.flush()
        runs = [
            subprocess.run(
                [str(ROOT / "target" / "release" / "examples" / "evaluate_rows"), str(SCENE), f.name, *PATHS],
                capture_output=True, text=True, check=True,
            ).stdout
            for _ in range(5)
        ]
    rust = sorted(float(r.split()[0]) for r in runs)[2]
    one = best_of(lambda: mc.evaluate(scene, PATHS, X, threads=1)) / n
    two = best_of(lambda: mc.evaluate(scene, PATHS, X, threads=2)) / n
    print(f"{n} rows of Ishigami, medians of 5")
    print(f"  Rust Subject::run       {rust * 1e6:8.3f} µs/row")
    print(f"  evaluate, 1 thread      {one * 1e6:8.3f} µs/row   overhead {(one - rust) * 1e6:.3f} µs/row")
    print(f"  evaluate, 2 threads     {two * 1e6:8.3f} µs/row   speed-up {one / two:.2f}×")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 200_000)
