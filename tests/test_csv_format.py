"""Vectorised CSV writing gives the same bytes as row-by-row formatting (issue 11, item 5)."""

import csv
import io
import math
import subprocess
import sys

import numpy as np

from corr_cad import GearDesign
from corr_cad.export.files import format_columns
from corr_cad.mechanics.row.solver import solve_forces


def _rowwise(columns, specs):
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    for row in zip(*(c.tolist() for c in columns), strict=True):
        w.writerow([format(v, s) for v, s in zip(row, specs, strict=True)])
    return buf.getvalue()


def test_format_columns_matches_row_by_row_formatting():
    rng = np.random.default_rng(0)
    n = 2000
    x = rng.standard_normal(n) * 10.0 ** rng.integers(-12, 12, n)
    x[:6] = [0.0, -0.0, math.nan, math.inf, -math.inf, 5e-324]
    cols = [rng.uniform(0, 360, n), np.arange(n) % 40 + 1, x, -x, np.round(x, 3)]
    got = format_columns(cols, ["%.6f", "%d", "%.9g", "%.9g", "%.9g"])
    assert got == _rowwise(cols, [".6f", "d", ".9g", ".9g", ".9g"])


def test_forces_csv_bytes_as_row_by_row(tmp_path):
    (tmp_path / "s.toml").write_text(
        '[export]\nformats = ["forces"]\n[load]\ninput_torque = 1.1e5\n'
        "[solver]\ncrank_angles_deg = [0.0, 7.5, 200.0]\n"
    )
    p = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "o", "--quiet"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert p.returncode == 0, p.stderr
    res = solve_forces(GearDesign(), 1.1e5, np.radians([0.0, 7.5, 200.0]))
    P, R = res.F_j.shape
    cols = [
        np.repeat(np.degrees(res.crank_angles), R),
        np.tile(np.arange(1, R + 1), P),
        np.degrees(np.mod(res.psi, 2 * np.pi)).ravel(),
    ] + [getattr(res, k).ravel() for k in ("F_j", "F_s", "F_n", "p_cam", "p_slot", "p_gear")]
    header = "crank_angle_deg,roller,psi_deg,F_j,F_s,F_n,p_cam,p_slot,p_gear\n"
    expected = header + _rowwise(cols, [".6f", "d", ".6f"] + [".9g"] * 6)
    assert (tmp_path / "o" / "forces.csv").read_text() == expected
