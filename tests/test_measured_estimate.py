"""The estimate of a measured profile follows the points the reader keeps.

A CSV's lines are counted up front (no parsing): they set the stride, and
the registration's memory and time follow the points kept of them, not the
file's size. A file with outliers far off the ring is refused in one line
by the stage that reads it, before any file is written.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from corr_cad.export.measured_io import csv_points_kept, read_measured
from corr_cad.run.budget.resources import estimate
from corr_cad.run.scene.scene import load_scene


def _ring(n: int) -> np.ndarray:
    from corr_cad.geometry.design import GearDesign
    from corr_cad.geometry.profile import working_profile

    w = working_profile(GearDesign())
    return w.points(np.linspace(0.0, 2 * np.pi, n, endpoint=False))


def _write(path, pts, fmt="%.4f", head="x,y\n", tail=True) -> None:
    text = "\n".join(f"{fmt % x},{fmt % y}" for x, y in pts)
    path.write_text(head + text + ("\n" if tail else ""))


@pytest.mark.parametrize(
    ("n", "cap", "head", "tail"),
    [
        (1000, None, "x,y\n", True),
        (1000, 300, "x,y\n", True),  # stride 4: 250 kept
        (1001, 250, "\ufeff# CMM export\n# probe 2 mm\nX, Y\n", False),  # stride 5: 201
        (999, 1000, "x,y\n", True),
    ],
)
def test_counted_lines_give_the_readers_stride_and_kept_points(tmp_path, n, cap, head, tail):
    path = tmp_path / "m.csv"
    _write(path, _ring(n), head=head, tail=tail)
    got = read_measured(path, max_points=cap)
    lines, kept = csv_points_kept(path, cap)
    assert (lines, kept) == (got.rows, len(got.points))
    # By hand: every stride-th of n rows, stride = ceil(n / cap).
    stride = 1 if cap is None or n <= cap else -(-n // cap)
    assert kept == (n + stride - 1) // stride


def _scene(tmp_path, name: str) -> object:
    (tmp_path / f"{name}.toml").write_text(
        '[export]\nformats = ["inspection", "forces"]\n[load]\ninput_torque = 1.1e5\n'
        f'[errors]\nmeasured_profile = "{name}.csv"\n'
    )
    return load_scene(tmp_path / f"{name}.toml")


def test_the_estimate_follows_the_points_not_the_bytes(tmp_path):
    pts = _ring(20_000)
    _write(tmp_path / "short.csv", pts, "%.4f")
    _write(tmp_path / "long.csv", pts, "%.12f")  # twice the bytes, the same points
    assert (tmp_path / "long.csv").stat().st_size > 1.7 * (tmp_path / "short.csv").stat().st_size
    a, b = (estimate(_scene(tmp_path, n), 1, "serial") for n in ("short", "long"))
    for stage in ("measured_profile", "inspection"):
        assert a.stages[stage].memory == b.stages[stage].memory
    # 250 bytes kept a point, 20,000 points.
    assert a.stages["measured_profile"].keeps == 250 * 20_000


def test_beyond_the_cap_the_estimate_counts_every_strideth_line(tmp_path):
    n = 250_001  # stride 2 at 200,000 points: 125,001 kept
    pts = _ring(n)
    with open(tmp_path / "big.csv", "w") as f:
        f.write("x,y\n")
        np.savetxt(f, pts, fmt="%.4f", delimiter=",")
    est = estimate(_scene(tmp_path, "big"), 1, "serial")
    assert est.stages["measured_profile"].keeps == 250 * 125_001


@pytest.mark.slow
def test_a_million_points_with_far_outliers_are_refused_in_one_line(tmp_path):
    pts = _ring(1_000_000)
    rng = np.random.default_rng(1)
    far = rng.random(len(pts)) < 0.1  # 10 %, at 2 to 3 times the radius
    pts[far] *= rng.uniform(2.1, 3.0, int(far.sum()))[:, None]
    with open(tmp_path / "far.csv", "w") as f:
        f.write("x,y\n")
        np.savetxt(f, pts, fmt="%.4f", delimiter=",")
    _scene(tmp_path, "far")
    p = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "far.toml", "--out", "out", "--quiet"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert p.returncode == 2
    lines = [ln for ln in p.stderr.splitlines() if ln.startswith("corr-cad: error")]
    assert len(lines) == 1 and "points far off the ring" in lines[0], p.stderr
    assert "remove such outliers" in lines[0]
    assert not (tmp_path / "out").exists()
