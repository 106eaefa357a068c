"""The bundled examples run without a single warning.

Every scene in ``templates/``, ``examples/quickstart.py`` and the inspection
demo (``benchmarks/synthetic_cmm.py``) is run as a user would run it; nothing
it prints may be a warning (a "has no effect" line, a validity or geometry
warning, or a Python warning).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.helpers import without_progress

ROOT = Path(__file__).resolve().parents[1]
#: Exit code each template is meant to give (montecarlo_gate fails its gate on purpose).
TEMPLATES = {
    "prototype": 0,
    "shop": 0,
    "montecarlo_gate": 1,
    "lost_motion_grade": 0,
    "compound": 0,
    "no_load_temperature": 0,
    "sizing": 0,
}


def _run(args, cwd):
    return subprocess.run(
        [sys.executable, "-W", "error", *args], cwd=cwd, capture_output=True, text=True
    )


def _warnings(r) -> list[str]:
    return [ln for ln in (r.stdout + r.stderr).splitlines() if "warning" in ln.lower()]


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(TEMPLATES))
def test_template_runs_without_warnings(tmp_path, name):
    scene = ROOT / "templates" / f"{name}.toml"
    r = _run(["-m", "corr_cad", "run", str(scene), "--out", "out"], tmp_path)
    assert r.returncode == TEMPLATES[name], r.stderr
    assert _warnings(r) == []


def test_quickstart_runs_without_warnings(tmp_path):
    r = _run([str(ROOT / "examples" / "quickstart.py"), "qs"], tmp_path)
    assert r.returncode == 0, r.stderr
    assert _warnings(r) == [] and without_progress(r.stderr) == ""


@pytest.mark.slow
def test_inspection_demo_runs_without_warnings(tmp_path):
    r = _run([str(ROOT / "benchmarks" / "synthetic_cmm.py"), "demo"], tmp_path)
    assert r.returncode == 0, r.stderr
    r = _run(["-m", "corr_cad", "run", "demo/inspect.toml", "--out", "demo/out"], tmp_path)
    assert r.returncode == 1  # the demo ring has faults on purpose
    assert _warnings(r) == []
    assert r.stderr.splitlines()[-1].startswith("corr-cad: inspection failed: ")
