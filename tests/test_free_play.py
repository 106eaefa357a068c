"""The free interval of a drive with bearing clearance, solved exactly and compiled
(:mod:`corr_cad.mechanics.drive.free_play`), gives the numpy search's answers
(``tests/free_row_reference.py``, golden sections and bisections over the polygon's
slices): on 20 seeded drives to 1e-9 arcmin, and the Monte Carlo's files as the search
wrote them (hashes taken from its runs): ``montecarlo.csv`` byte for byte, the summary's
full-precision figures to 12 digits. A preloaded row's cam centre is settled position by
position, so the samples no longer depend on the chunking in their last bits, as they
did (1e-13 arcmin) when every position iterated until the last of its block settled."""

from __future__ import annotations

import hashlib
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors as ME
from corr_cad.mechanics.crank.bearing import EccentricBearing
from corr_cad.mechanics.drive import drive as drive_module
from corr_cad.mechanics.drive.drive import DriveSolver
from corr_cad.mechanics.drive.drive_numerics import free_row
from corr_cad.mechanics.row.solver_geometry import cycle_angles

from . import free_row_reference as reference

DESIGN = GearDesign()
R = DESIGN.roller_count
ARCMIN = 180.0 * 60.0 / math.pi
ROOT = Path(__file__).resolve().parents[1]


def _drive(seed: int) -> tuple[DriveSolver, float]:
    """Seeded drive ``seed`` of 20: clearances 0-20 um, a cam phase error, row B's own
    errors; rollers 0-4 um undersize (preloaded to free rows); both contact laws."""
    rng = np.random.default_rng(seed)

    def errors(phase: float = 0.0) -> ME:
        return ME(
            cam_radius_error=float(rng.normal(0.0, 0.002)),
            eccentricity_error=float(rng.normal(0.0, 0.002)),
            roller_radius_errors=tuple(rng.normal(-0.004 * (seed % 4) / 3, 0.001, R)),
            cam_phase_error=phase,
        )

    clearance = 0.020 * seed / 19
    law = "palmgren" if seed % 2 else "nonlinear"
    solver = DriveSolver(
        DESIGN,
        cycle_angles(37),
        errors=errors(math.radians(float(rng.normal(0.0, 0.01)))),
        errors_b=errors(),
        bearing=EccentricBearing(40, 6.0, 12.0, diametral_clearance=clearance),
        contact_model=law,
    )
    return solver, clearance


def _same(x, y, what):
    """Equal to 1e-9 arcmin where finite, and infinite at the same places."""
    x, y = np.asarray(x), np.asarray(y)
    assert np.array_equal(np.isfinite(x), np.isfinite(y)), what
    assert np.array_equal(x[~np.isfinite(x)], y[~np.isfinite(y)]), what
    fin = np.isfinite(x)
    assert np.all(np.abs(x[fin] - y[fin]) * ARCMIN <= 1e-9), what


@pytest.mark.parametrize("seed", range(20))
def test_each_row_s_free_interval_is_the_search_s(seed):
    solver, clearance = _drive(seed)
    geo = solver.geo_joined
    a = np.where(geo.loadable, geo.advance, 0.0)
    g = np.where(geo.loadable, geo.gap, -np.inf)
    e = DESIGN.eccentricity
    for sl in (slice(0, R), slice(R, 2 * R)):
        want = reference.free_row(a[:, sl], g[:, sl], solver.n[:, sl], clearance / 2, e, True)
        got = free_row(a[:, sl], g[:, sl], solver.n[:, sl], clearance / 2, e, True)
        _same(got[0], want[0], "rev")
        _same(got[1], want[1], "fwd")
        # A preloaded row's start for its cam's equilibrium: the search's point (a start only:
        # to 1e-6 of the clearance; the interval it leads to is compared below).
        locked = ~(want[1] > want[0])
        np.testing.assert_allclose(got[2][locked], want[2][locked], rtol=0, atol=1e-6 * clearance)


def test_the_seeds_cover_free_and_preloaded_rows():
    """The 20 drives hold rows that turn freely and rows preloaded at every position."""
    free = locked = 0
    for seed in (2, 4, 16):
        solver, clearance = _drive(seed)
        rev, fwd = solver.free_interval(solve=False)
        free += int(np.sum(fwd > rev))
        locked += int(np.sum(~(fwd > rev)))
    assert free > 0 and locked > 0


@pytest.mark.parametrize("seed", [1, 4, 8, 16, 18])
def test_the_drive_s_free_interval_is_the_search_s(seed, monkeypatch):
    """Both rows joined, preloaded rows held at their cams' equilibria (each position's
    Newton stopped as it settles), the tight positions solved at zero moment: the
    interval the search and the Newton that ran every position to the last gave."""
    solver, _ = _drive(seed)
    got = solver.free_interval()
    monkeypatch.setattr(drive_module, "free_row", reference.free_row)
    monkeypatch.setattr(DriveSolver, "_row_centre", reference.row_centre)
    want = solver.free_interval()
    _same(got[0], want[0], "rev")
    _same(got[1], want[1], "fwd")


@pytest.mark.parametrize("law", ["nonlinear", "palmgren"])
def test_the_nominal_drive_s_free_rotation_is_its_clearance_s(law):
    """The nominal rows pin ``v`` to one point (every roller touching: the round-off
    allowance decides): each row turns by ``Pd / e`` at the crank, as the search gave."""
    pd = 0.005
    solver = DriveSolver(
        DESIGN,
        cycle_angles(37),
        bearing=EccentricBearing(40, 6.0, 12.0, diametral_clearance=pd),
        contact_model=law,
    )
    rev, fwd = solver.free_interval(solve=False)
    np.testing.assert_allclose(fwd - rev, pd / DESIGN.eccentricity, rtol=1e-9)
    geo = solver.geo_joined
    a = np.where(geo.loadable, geo.advance, 0.0)
    g = np.where(geo.loadable, geo.gap, -np.inf)
    for sl in (slice(0, R), slice(R, 2 * R)):
        args = (a[:, sl], g[:, sl], solver.n[:, sl], pd / 2, DESIGN.eccentricity)
        want, got = reference.free_row(*args), free_row(*args)
        _same(got[0], want[0], "rev")
        _same(got[1], want[1], "fwd")


def test_a_row_with_no_roller_in_reach_turns_freely_by_its_clearance():
    """Hand value: every roller far away (gaps of -1 mm) and ``n_x = 0`` for none: the
    polygon is the whole slice band, so ``e fwd = x_r + c`` at ``y = 0`` exactly when
    the nearest right roller's line is vertical (``n = (1, 0)``, ``x_r = -g``)."""
    c, e = 0.002, 3.5
    g = np.array([[-1.0, -1.0]])
    n = np.array([[[1.0, 0.0], [-1.0, 0.0]]])
    a = e * n[..., 0]
    rev, fwd = free_row(a, g, n, c, e)
    assert fwd[0] == pytest.approx((1.0 + c) / e, rel=1e-15)
    assert rev[0] == pytest.approx(-(1.0 + c) / e, rel=1e-15)


def test_a_drive_monte_carlo_with_preloaded_rows_is_independent_of_chunking():
    """Bit for bit, with rows preloaded at some positions (their cams' centres solved)."""
    from corr_cad.tolerance.montecarlo import Distribution, monte_carlo

    tol = {
        "roller_radius": Distribution("uniform", 0.002),
        "cam_radius": Distribution("uniform", 0.003),
    }
    mc = {"bearing": EccentricBearing(40, 6.0, 12.0, 0.005), "contact_model": "palmgren"}
    runs = [monte_carlo(DESIGN, 1.1e5, tol, 12, 3, 36, drive=mc, chunk=c) for c in (12, 5, 1)]
    for run in runs[1:]:
        np.testing.assert_array_equal(
            run.metrics["backlash_arcmin"], runs[0].metrics["backlash_arcmin"]
        )


def _rounded(x):
    """A JSON value with its floats to 12 significant digits."""
    if isinstance(x, float):
        return float(f"{x:.12g}")
    if isinstance(x, dict):
        return {k: _rounded(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_rounded(v) for v in x]
    return x


def _digest(path: Path, exact: bool) -> str:
    """sha256 of the file's bytes; not ``exact``: of a JSON's figures to 12 digits."""
    if path.suffix == ".json" and not exact:
        text = json.dumps(_rounded(json.loads(path.read_text())), sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()
    return hashlib.sha256(path.read_bytes()).hexdigest()


# The files the numpy search wrote (main at e8c0d88), per scene (:func:`_digest`).
DRIVE_MC = """[export]
formats = ["montecarlo"]
[load]
input_torque = 1.1e5
[solver]
model = "drive"
contact_law = "palmgren"
[errors]
cam_phase_error_deg = 0.003
[errors.row_b]
roller_radius_error = -0.001
[tolerances]
roller_radius = { uniform = 0.002 }
cam_radius = { uniform = 0.003 }
[montecarlo]
samples = %d
positions = 36
seed = %d
%s
[bearings.eccentric]
needles = 40
needle_diameter = 6.0
needle_length = 12.0
diametral_clearance = 0.005
"""
DATASHEET = "datasheet_positions_per_mesh = 2\n[checks]\nmax_lost_motion_arcmin = 5.0"
HASHES = {
    "forces": (
        DRIVE_MC % (40, 3, ""),
        {
            "montecarlo.csv": "a42842c86f1f8d36e79c814684c8a6470db0f8f8e2a8f7f17bc0aba99bda0eda",
            "montecarlo_summary.json": (
                "ed83e220ef18e7ab331ae3a549235e96820017dd046b290fbed62d0a753cdf21"
            ),
        },
    ),
    "datasheet": (
        DRIVE_MC % (12, 4, DATASHEET),
        {
            "montecarlo.csv": "c6a93b9942a9c6fd835ff79bd2d6ba32d5956fb3445ac6700f8c020002adebad",
            "montecarlo_summary.json": (
                "06677bc3f2f638eb41d5c3afcbba7a928b2293ed7a457cf4cc52343d206303cb"
            ),
        },
    ),
    "template montecarlo_gate": (
        None,
        {
            "montecarlo.csv": "5d406b08a9cbaa3d0a4e952064f58a0a8eb71ec245419852f8d2430445655171",
            "montecarlo_summary.json": (
                "5868c73ce40fd98954495d94ac699d579ee40b0ecd76808e0d3c0aad6ddbf597"
            ),
        },
    ),
    "template lost_motion_grade": (
        None,
        {
            "allocation.csv": "eb7fe7d9df6d55706bf94236087385208321d6b784d472ce915350730f6bcd48",
            "allocation.json": "d5ea1cf6cf6a607eb838cd7ab726b89faf80ddba2771d0cbbfeb7a268493e7b8",
        },
    ),
}


@pytest.mark.parametrize(
    "case",
    [
        "forces",
        "datasheet",
        pytest.param("template montecarlo_gate", marks=pytest.mark.slow),
        pytest.param("template lost_motion_grade", marks=pytest.mark.slow),
    ],
)
def test_monte_carlo_files_are_the_search_s_byte_for_byte(case, tmp_path):
    text, hashes = HASHES[case]
    if text is None:
        scene = ROOT / "templates" / (case.split()[1] + ".toml")
    else:
        scene = tmp_path / "drive_mc.toml"
        scene.write_text(text)
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    run = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(out)],
        capture_output=True,
        text=True,
        env=env,
        cwd=tmp_path,
    )
    assert run.returncode in (0, 1), run.stderr  # montecarlo_gate's gate fails by design
    for name, want in hashes.items():
        # The templates (the paper's row) keep every byte; the drive's CSV too.
        assert _digest(out / name, text is None) == want, name
