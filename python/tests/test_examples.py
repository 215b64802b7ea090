"""The examples run and their own checks pass (OpenTURNS against `mc-study report`,
SALib's Morris ranking against the bundled circuit-breaker study)."""

import os
import subprocess
import sys
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def run(script, *args):
    done = subprocess.run([sys.executable, str(EXAMPLES / script), *map(str, args)], capture_output=True, text=True, env=os.environ)
    print(done.stdout)
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


def test_openturns_sobol_indices_agree_with_the_report(tmp_path):
    out = run("openturns_sobol.py", tmp_path / "out")
    assert "agree within their bootstrap intervals" in out


def test_salib_morris_names_the_clearances_that_matter():
    out = run("salib_morris_c60.py", 4)
    assert "strongest clearance for all 9 outputs" in out
