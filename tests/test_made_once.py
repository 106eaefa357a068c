"""Work a run need not do, counted (no timer): shared work done once, fewer cyclic collections.

With ``[first_stage]`` the gears' measured outlines feed the DXF, the solids and
the drive in the main process and the STEP stage's exact volumes in the pool
worker: the main process makes them before the pool forks, and the worker
inherits them. The test wraps the outline's maker in the real CLI (a
subprocess) and counts the calls per process.
"""

from __future__ import annotations

import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest

pytest.importorskip("OCP")

ROOT = Path(__file__).resolve().parents[1]

WRAPPER = """
import os, runpy, sys
import corr_cad.geometry.gear_outline as go

made = go.tooth_segments

def counted(g):
    caller = sys._getframe(1).f_code.co_name
    print(f"MADE {os.getpid()} {g.teeth} {caller}", file=sys.stderr, flush=True)
    return made(g)

go.tooth_segments = counted
print(f"MAIN {os.getpid()}", file=sys.stderr, flush=True)
sys.argv = ["corr_cad", "run", sys.argv[1], "--out", sys.argv[2], "--quiet", "--workers", "2"]
runpy.run_module("corr_cad", run_name="__main__")
"""


@pytest.mark.slow
def test_gear_outlines_are_made_once_for_the_main_process_and_the_step_worker(tmp_path):
    text = (ROOT / "templates" / "compound.toml").read_text()
    head, _, _ = text.partition("[export]")
    scene = tmp_path / "compound.toml"
    scene.write_text(head + '[export]\nformats = ["dxf", "png", "step"]\ntolerance = 0.001\n')
    wrapper = tmp_path / "wrapper.py"
    wrapper.write_text(WRAPPER)
    r = subprocess.run(
        [sys.executable, str(wrapper), str(scene), str(tmp_path / "out")],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    lines = [ln.split() for ln in r.stderr.splitlines()]
    main = next(ln[1] for ln in lines if ln[:1] == ["MAIN"])
    made = Counter((ln[1] == main, ln[2], ln[3]) for ln in lines if ln[:1] == ["MADE"])
    # Each gear's polyline outline once, in the main process, before the pool forked.
    for teeth in ("18", "36", "90"):
        assert made[(True, teeth, "_approximate_gear")] == 1
        assert made[(False, teeth, "_approximate_gear")] == 0
        # The STEP worker's own B-splines (the main process draws no STEP).
        assert made[(False, teeth, "spline_gear")] == 1
    assert (tmp_path / "out" / "crank_gear.step").is_file()


def test_a_command_runs_with_fewer_cyclic_collections_and_restores_the_threshold(monkeypatch):
    """``cli.main`` raises the youngest generation's threshold while the command
    runs (the collections a run pays for) and leaves the caller's as it was."""
    import gc

    from corr_cad.run import cli

    seen = []
    monkeypatch.setattr(cli, "_main", lambda argv: seen.append(gc.get_threshold()) or 0)
    before = gc.get_threshold()
    assert cli.main([]) == 0
    assert seen == [(max(before[0], cli.GC_THRESHOLD0), *before[1:])]
    assert seen[0][0] >= 10_000
    assert gc.get_threshold() == before
