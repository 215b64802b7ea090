"""mc-study from Python: simulate mechanisms, run tolerance studies and evaluate scenes
over parameter rows in parallel, on the same Rust engine as the ``mc-study`` command.

The engine does all the work; this package converts between it and numpy / pyarrow.
See docs/python.md for the guide.
"""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Union

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from . import _native
from ._native import McStudyError

__all__ = ["Scene", "Run", "Study", "simulate", "evaluate", "Evaluation", "McStudyError"]


class Scene:
    """A scene file: a mechanism (simulated) or a function scene (evaluated).

    Parameters are set by the same paths as ``mc-study simulate --set``; a value is a
    number in SI units or a string with a unit, ``scene.set("joints.J3.clearance", "0.1 mm")``.
    """

    def __init__(self, native: "_native.Scene"):
        self._native = native

    @staticmethod
    def load(path: Union[str, os.PathLike]) -> "Scene":
        """Reads a scene file; paths inside it are relative to it."""
        return Scene(_native.Scene.load(os.fspath(path)))

    @staticmethod
    def from_yaml(text: str, name: str = "scene") -> "Scene":
        """Parses scene text; ``name`` stands for the file in error messages."""
        return Scene(_native.Scene.from_yaml(text, name))

    def set(self, path: str, value: Union[float, str]) -> "Scene":
        """Sets a parameter path (SI number, or a string with a unit); returns the scene."""
        self._native.set(path, value)
        return self

    def paths(self) -> List[str]:
        """Every parameter path the scene accepts (``mc-study paths``)."""
        return self._native.paths()

    def outputs(self) -> List[str]:
        """The names of the scene's outputs (a mechanism's probes), in order."""
        return self._native.outputs()


@dataclass
class Run:
    """What one simulation measured: the probes (SI values, NaN where a probe has no
    value, with the reason in ``probe_errors``), the run's diagnostics, the error that
    ended it early (None if it ran to its end), and the trajectory."""

    probes: Dict[str, float]
    probe_errors: Dict[str, str]
    diagnostics: Dict[str, float]
    error: Optional[str]
    trajectory: pa.Table
    report: str = field(repr=False)

    def arrays(self) -> Dict[str, np.ndarray]:
        """The trajectory's columns as numpy arrays."""
        return {name: col.to_numpy() for name, col in zip(self.trajectory.column_names, self.trajectory.columns)}

    def __str__(self) -> str:
        return self.report


def simulate(scene: Scene) -> Run:
    """Simulates a mechanism scene as ``mc-study simulate`` does (the GIL is released)."""
    with tempfile.TemporaryDirectory(prefix="mc-study-") as tmp:
        path = os.path.join(tmp, "trajectory.parquet")
        r = _native.simulate(scene._native, path)
        table = pq.read_table(path) if os.path.exists(path) else pa.table({})
    return Run(
        probes=dict(r["probes"]),
        probe_errors=dict(r["probe_errors"]),
        diagnostics=dict(r["diagnostics"]),
        error=r["error"],
        trajectory=table,
        report=r["text"],
    )


class Study:
    """A study file, run with the same store, resume and determinism as ``mc-study run``."""

    def __init__(self, native: "_native.Study"):
        self._native = native
        self._out: Optional[str] = None

    @staticmethod
    def load(path: Union[str, os.PathLike], samples: Optional[int] = None) -> "Study":
        """Reads a study file (``samples`` overrides its sample count, as ``--samples``)."""
        return Study(_native.Study.load(os.fspath(path), samples))

    def run(
        self,
        out: Optional[Union[str, os.PathLike]] = None,
        threads: Optional[int] = None,
        shard: Optional[str] = None,
    ) -> Optional[pa.Table]:
        """Runs the study (or the shard ``"i/n"``) into ``out`` (default: the study's
        ``output``), resuming what is there. Returns ``results.parquet`` as a table once
        every sample is in, None for a shard of an unfinished study."""
        out_dir, merged = self._native.run(None if out is None else os.fspath(out), threads, shard)
        self._out = out_dir
        return pq.read_table(os.path.join(out_dir, "results.parquet")) if merged else None

    def summary(self, out: Optional[Union[str, os.PathLike]] = None) -> dict:
        """The statistics of a merged run (``summary.json``) of ``out``, or of the last run."""
        out_dir = os.fspath(out) if out is not None else (self._out or self._native.output_dir)
        with open(os.path.join(out_dir, "summary.json")) as f:
            return json.load(f)

    def scene(self) -> Scene:
        """The study's scene, with its fidelity settings applied."""
        return Scene(self._native.scene())

    def outputs(self) -> List[str]:
        """The study's outputs, in order."""
        return self._native.outputs()

    def parameters(self) -> List[str]:
        """The study's parameter paths, in order."""
        return self._native.parameters()


@dataclass
class Evaluation:
    """The outputs of ``evaluate`` (n × k, NaN where a row failed), their names, and each
    row's failure reason (None where it ran)."""

    values: np.ndarray
    outputs: List[str]
    errors: List[Optional[str]]

    def __array__(self, dtype=None, copy=None):
        return self.values if dtype is None else self.values.astype(dtype)


def evaluate(
    subject: Union[Scene, Study],
    paths: Sequence[str],
    X,
    threads: Optional[int] = None,
) -> Evaluation:
    """The outputs of ``subject`` for each row of ``X`` (n × len(paths), SI values of the
    parameter ``paths``), run in parallel on ``threads`` (default: every core) with the GIL
    released. A scene gives all its outputs, a study its own. The same inputs give
    bit-identical values whatever the thread count."""
    X = np.ascontiguousarray(np.asarray(X, dtype="<f8"))
    if X.ndim == 1:
        X = X.reshape(-1, len(paths))
    if X.ndim != 2 or X.shape[1] != len(paths):
        raise McStudyError(f"X must be n × {len(paths)} (one column per path), not {X.shape}")
    native = subject._native
    raw, errors = _native.evaluate(native, list(paths), X.tobytes(), X.shape[0], threads)
    names = native.outputs()
    values = np.frombuffer(raw, dtype="<f8").reshape(X.shape[0], len(names)).copy()
    return Evaluation(values=values, outputs=names, errors=list(errors))
