"""Issue 21: bounded memory, files and time for every accepted scene; progress that says so.

Every run is the real CLI in a child process (``python -m corr_cad``), under
an address-space cap (``prlimit --as``) so that a regression fails here
instead of taking the machine's memory. Peak memory is the child's
``ru_maxrss`` (``RUSAGE_CHILDREN`` of a fresh parent), on small scenes only:
the grid of large scenes is ``corr-cad bench --study resources``.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import is_progress_line, without_progress

CAP = 3 * 1024**3  # address space of every child run here
pytestmark = pytest.mark.skipif(shutil.which("prlimit") is None, reason="needs prlimit")


def _cmd(*args) -> list[str]:
    return ["prlimit", f"--as={CAP}", sys.executable, "-m", "corr_cad", *map(str, args)]


def _run(folder: Path, text: str, *args, timeout=600) -> subprocess.CompletedProcess:
    (folder / "s.toml").write_text(text)
    return subprocess.run(
        _cmd("run", "s.toml", "--out", "out", *args),
        capture_output=True,
        text=True,
        cwd=folder,
        timeout=timeout,
    )


def _peak(folder: Path, text: str, *args, timeout=600) -> tuple[subprocess.CompletedProcess, float]:
    """The CLI from a fresh parent; the parent reports its only child's peak RSS (MB)."""
    (folder / "s.toml").write_text(text)
    code = textwrap.dedent(
        f"""
        import resource, subprocess, sys
        p = subprocess.run({_cmd("run", "s.toml", "--out", "out", *args)!r},
                           capture_output=True, text=True)
        sys.stderr.write(p.stderr)
        sys.stdout.write(p.stdout)
        print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024)
        sys.exit(p.returncode)
        """
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=folder, timeout=timeout
    )
    return proc, float(proc.stdout.split()[-1])


def _refusal(proc) -> str:
    lines = [ln for ln in without_progress(proc.stderr).splitlines() if ln.strip()]
    assert proc.returncode == 2, proc.stderr
    assert len(lines) == 1 and lines[0].startswith("corr-cad: error: "), proc.stderr
    return lines[0]


def _fits(line: str) -> str:
    return re.search(r"; (\S+)(?: angles)? would fit", line).group(1)


Z1000 = """
[design]
tooth_count = 1000
eccentricity = 0.05
roller_radius = 0.3
[export]
formats = ["interference"]
"""


# --- refusals that protect the machine ------------------------------------------------
def test_exact_interference_of_a_z1000_drive_refused_with_a_value_that_fits(tmp_path):
    """100,000 positions x 1001 rollers: took all 24 GB; now one line, before any work."""
    proc, rss = _peak(tmp_path, Z1000 + "interference_positions = 100000\n")
    line = _refusal(proc)
    assert line.startswith("corr-cad: error: [export] interference_positions = 100000: ")
    assert "clearance.csv" in line and "--max-output" in line and "[budget] output_gb" in line
    assert rss < 400  # refused before the work (the memory says so; no wall clock)
    assert not (tmp_path / "out").exists()
    ok = int(_fits(line))
    from corr_cad.run.budget.resources import budget_for, estimate
    from corr_cad.run.scene.scene import load_scene

    scene = load_scene(tmp_path / "s.toml")
    from dataclasses import replace

    assert estimate(replace(scene, interference_positions=ok)).output_bytes <= 1024**3
    assert estimate(replace(scene, interference_positions=ok + 1)).output_bytes > 1024**3
    assert budget_for(scene).output_bytes == 1024**3


@pytest.mark.slow
def test_clearance_memory_does_not_grow_with_the_positions(tmp_path):
    """The exact clearance is computed and written in chunks (it held 400 bytes a cell)."""
    scene = "[design]\ntooth_count = 99\neccentricity = 0.5\nroller_radius = 1.5\n"
    scene += '[export]\nformats = ["interference"]\ninterference_positions = {}\n'
    small, rss_small = _peak(tmp_path, scene.format(500), "--executor", "serial")
    big, rss_big = _peak(tmp_path, scene.format(6000), "--executor", "serial")
    assert small.returncode == 0 and big.returncode == 0, big.stderr
    rows = (tmp_path / "out" / "clearance.csv").read_text().count("\n") - 1
    assert rows == 6000 * 100
    # 540,000 more cells: 216 MB at 400 bytes a cell before, ~10 MB now.
    assert rss_big - rss_small < 60, (rss_small, rss_big)


@pytest.mark.slow
def test_forces_csv_is_not_held_whole_in_memory(tmp_path):
    """forces.csv was one string of one tuple of Python floats: 730 bytes a cell at peak."""
    scene = '[export]\nformats = ["forces"]\n[load]\ninput_torque = 1.1e5\n'
    scene += "[solver]\npositions = 40000\n"
    proc, rss = _peak(tmp_path, scene, "--executor", "serial")
    assert proc.returncode == 0, proc.stderr
    cells = 40000 * 26
    assert rss < 100 + 500 * cells / 2**20, rss  # 596 MB; it was ~820


def test_assembly_meshes_beyond_the_output_budget_refused(tmp_path):
    """360 assembly angles x STL wrote 3 GB (889 MB at a coarser chord) with nothing to stop it."""
    angles = ", ".join(f"{a}.0" for a in range(360))
    proc = _run(tmp_path, f'[export]\nformats = ["stl"]\nassembly_angles_deg = [{angles}]\n')
    line = _refusal(proc)
    assert line.startswith("corr-cad: error: [export] assembly_angles_deg = 360 angles: ")
    assert "of files" in line and "the output budget is 1 GB (default)" in line
    assert int(_fits(line)) < 360
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_budget_from_the_scene_and_the_command_line(tmp_path):
    scene = '[export]\nformats = ["stl"]\nchord_tolerance = 0.01\n'
    line = _refusal(_run(tmp_path, scene, "--max-output", "0.001"))
    assert "the output budget is 0.001 GB (--max-output)" in line
    small = scene + "[budget]\noutput_gb = 0.001\n"
    line = _refusal(_run(tmp_path, small))
    assert "the output budget is 0.001 GB ([budget] output_gb)" in line
    proc = _run(tmp_path, small, "--max-output", "1", "--quiet")  # the flag wins
    assert proc.returncode == 0, proc.stderr
    line = _refusal(_run(tmp_path, scene, "--max-memory", "1000"))
    assert "--max-memory 1000: more than this machine's" in line
    line = _refusal(_run(tmp_path, scene, "--max-memory", "-1"))
    assert "--max-memory -1: allowed range is" in line


def test_memory_refusal_names_the_budget_and_the_override(tmp_path):
    scene = '[export]\nformats = ["forces"]\n[load]\ninput_torque = 1.1e5\n'
    line = _refusal(_run(tmp_path, scene + "[solver]\npositions = 1000000\n"))
    assert "[solver] positions = 1000000: the run would need about" in line
    assert "the budget is 3 GB (default)" in line
    # the budget that holds it: 9.18 GB and a tenth, rounded up (or: more than this machine has)
    assert "--max-memory 11 (or [budget] memory_gb = 11)" in line or "GB allowed here" in line
    ok = int(_fits(line))
    from corr_cad.run.budget.resources import GB, estimate
    from corr_cad.run.scene.scene import parse_scene

    def est(p):
        return estimate(
            parse_scene(
                {
                    "export": {"formats": ["forces"]},
                    "load": {"input_torque": 1.1e5},
                    "solver": {"positions": p},
                }
            )  # fmt: skip
        ).memory

    assert est(ok) <= 3 * GB < est(ok + 1)


# --- a large measured profile streams ---------------------------------------------------
def _profile(n: int) -> np.ndarray:
    Z, RJ, E, R = 25, 135.0, 3.5, 8.0
    L = RJ + R
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)

    def locus(t):
        psi = Z * t
        s = E * np.cos(psi) + np.sqrt(L * L - (E * np.sin(psi)) ** 2)
        return np.stack([s * np.sin(t), s * np.cos(t)], axis=1)

    d = locus(t + 1e-6) - locus(t - 1e-6)
    tang = d / np.linalg.norm(d, axis=1)[:, None]
    nrm = np.stack([-tang[:, 1], tang[:, 0]], axis=1)
    p = locus(t)
    nrm *= np.sign(np.sum(nrm * p, axis=1))[:, None]
    return p + R * nrm


@pytest.mark.slow
def test_a_two_million_row_measured_profile_streams(tmp_path):
    """Read in blocks, every value parsed, 1 row in 10 kept and said so; memory bounded."""
    with open(tmp_path / "m.csv", "w") as f:
        f.write("x,y\n")
        np.savetxt(f, _profile(2_000_000), fmt="%.4f", delimiter=",")
    scene = '[export]\nformats = ["inspection"]\n[errors]\nmeasured_profile = "m.csv"\n'
    proc, rss = _peak(tmp_path, scene, "--executor", "serial")
    assert proc.returncode == 0, proc.stderr
    assert "measured profile: 2000000 points read, 1 in 10 kept (200000 points" in proc.stdout
    read = json.loads((tmp_path / "out" / "manifest.json").read_text())["measured_profile"]
    assert read["read"] == {"rows": 2_000_000, "kept": 200_000, "stride": 10}
    assert read["points"] == 200_000
    assert rss < 450, rss  # the whole file, then a list of rows: ~1.5 GB before


@pytest.mark.slow
def test_a_bad_value_beyond_the_kept_rows_is_still_found(tmp_path):
    pts = _profile(400_001)
    lines = ["x,y"] + [f"{x:.4f},{y:.4f}" for x, y in pts]
    lines[8] = "1.0,abc"  # data row 7 (from 0): not one of the kept (0, 3, 6, 9, ...)
    (tmp_path / "m.csv").write_text("\n".join(lines) + "\n")
    scene = '[export]\nformats = ["inspection"]\n[errors]\nmeasured_profile = "m.csv"\n'
    line = _refusal(_run(tmp_path, scene))
    assert "m.csv': line 9: x,y = '1.0,abc': a value is not a number" in line


# --- time: a warning, and progress at least every 5 s -----------------------------------
def _lines_until(folder: Path, text: str, *args, until) -> list[str]:
    """stderr lines of a run, read until ``until(lines)`` holds; then the run is ended.

    Event-driven: the run is stopped at the line the test waits for, however
    long the machine takes to get there (a hang is ended by the time-out)."""
    (folder / "s.toml").write_text(text)
    p = subprocess.Popen(
        _cmd("run", "s.toml", "--out", "out", *args),
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        text=True,
        cwd=folder,
    )
    got: list[str] = []
    import threading

    def read():
        for line in p.stderr:
            got.append(line.rstrip("\n"))
            if until(got):
                break
        p.terminate()

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    reader.join(600)  # ends a hung test only
    p.terminate()
    p.wait(timeout=600)
    return got


SWEEPS = '[export]\nformats = ["sweeps"]\n[load]\ninput_torque = 1.1e5\n[sweeps]\npoints = {}\n'


@pytest.mark.slow
def test_sweeps_warn_and_report_progress_with_an_honest_time_left(tmp_path):
    """[sweeps] points = 1000 ran 174 s with two lines: "280h22m left", then 100 %.

    Structure only, at any load: the time warning names the key, and the run
    prints counter lines of the sweeps (count, rate, time left). When the
    lines come and what time left they state follow from the rules, tested on
    a fake clock (tests/test_progress.py); how far the stated time left is
    from the real one is measured by ``corr-cad bench --study progress``."""

    def two_counter_lines(lines):
        return sum(bool(SWEEP_LINE.match(ln)) for ln in lines) >= 2

    got = _lines_until(
        tmp_path, SWEEPS.format(150), "--executor", "serial", "--warn-time", "2",
        until=two_counter_lines,
    )  # fmt: skip
    text = "\n".join(got)
    assert "corr-cad: warning: the run would take about" in text
    assert "[sweeps] points = 150: " in text and "--warn-time S" in text
    counters = [m for m in map(SWEEP_LINE.match, got) if m]
    assert len(counters) >= 2, text
    done = [int(m.group(1)) for m in counters]
    assert done == sorted(done) and all(m.group(2) == "900" for m in counters)  # 6 x 150
    for ln in got:
        assert ln.startswith("corr-cad: ") or is_progress_line(ln), ln


#: A counter line of the sweeps: ``sweeps: 18/900 points (2%), 1.5 points/s, 9m58s left``.
SWEEP_LINE = re.compile(
    r"^\s*sweeps: (\d+)/(\d+) points \(\d+%\), \S+ points/s, "
    r"(?:(?:estimated )?(?:\d+s|\d+m\d\ds|\d+h\d\dm)|\?) left$"
)


@pytest.mark.slow
def test_allocation_of_many_samples_warns_and_shows_progress(tmp_path):
    """100,000 samples were estimated at "0.1 s" and showed nothing for 90 s."""
    scene = (
        '[export]\nformats = ["allocation"]\n[load]\ninput_torque = 1.1e5\n'
        "[checks]\nmax_gear_force = 5000.0\n[tolerances]\nroller_radius = { normal = 0.001 }\n"
        "[montecarlo]\nallocation_samples = 100000\npositions = 100000\n"
    )

    def two_counter_lines(lines):
        return sum("allocation:" in ln and is_progress_line(ln) for ln in lines) >= 2

    got = _lines_until(tmp_path, scene, "--workers", "1", until=two_counter_lines)
    text = "\n".join(got)
    m = re.search(r"warning: the run would take about (\S+) \(allocation", text)
    assert m and ("m" in m.group(1) or "h" in m.group(1)), text
    assert "[montecarlo] allocation_samples = 100000: " in text
    assert sum("allocation:" in ln and is_progress_line(ln) for ln in got) >= 2, text


# --- the estimate is never below the peak (small scenes; the grid is the benchmark) -----
SMALL = {
    "forces": '[export]\nformats = ["forces"]\n[load]\ninput_torque = 1.1e5\n',
    "clearance": '[export]\nformats = ["interference", "png"]\n',
    "mesh": '[export]\nformats = ["stl", "interference"]\ninterference_method = "mesh"\n'
    "interference_positions = 2\nchord_tolerance = 0.01\n",
    "montecarlo": '[export]\nformats = ["montecarlo"]\n[load]\ninput_torque = 1.1e5\n'
    "[tolerances]\nroller_radius = { normal = 0.001 }\n[montecarlo]\nsamples = 300\n",
    "dxf": '[export]\nformats = ["dxf", "cmm", "report"]\n',
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SMALL))
def test_small_runs_stay_within_their_estimate(tmp_path, name):
    from corr_cad.run.budget.resources import estimate
    from corr_cad.run.scene.scene import load_scene

    proc, rss = _peak(tmp_path, SMALL[name], "--executor", "serial")
    assert proc.returncode in (0, 1), proc.stderr
    est = estimate(load_scene(tmp_path / "s.toml"), 1, "serial").memory / 2**20
    assert rss <= est, (name, rss, est)
    assert f"estimate: peak memory ~{est:.0f} MB (budget 3072 MB)" in proc.stdout


def test_every_stage_has_an_estimator():
    """A new stage (a datasheet, a modification study) registers its cost in run/budget/costs.py."""
    from corr_cad.run.budget.costs import ESTIMATORS
    from corr_cad.run.stages.stages import STAGES

    assert sorted(STAGES) == sorted(ESTIMATORS)


def test_files_beyond_the_free_disk_refused(tmp_path, monkeypatch):
    """The output folder's disk is asked too (its free space faked at 1 MB)."""
    import shutil
    from collections import namedtuple

    from corr_cad.errors import SceneError
    from corr_cad.run.budget.resources import check_disk, estimate
    from corr_cad.run.scene.scene import parse_scene

    est = estimate(parse_scene({"export": {"formats": ["stl"]}}), 1, "serial")
    check_disk(est, tmp_path / "new" / "out")  # the real disk has room
    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda p: usage(10**9, 10**9 - 2**20, 2**20))
    with pytest.raises(SceneError, match=r"has 1 MB free; free some space or choose"):
        check_disk(est, tmp_path / "new" / "out")
