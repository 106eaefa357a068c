"""The compiled cam centre of a preloaded row (:mod:`corr_cad.mechanics.drive.drive_centre`)
against the numpy Newton (:meth:`DriveSolver._row_centre`) on the 20 seeded drives of
``tests/test_free_play.py`` (clearances 0-20 um, phase errors, row B's own errors, both
contact laws): the same centres to 1e-12 mm where the rollers hold the cam, and the
same free intervals to 1e-9 arcmin. Where the cam falls free of every roller (no force
left: any centre there balances) both end with no force. The Monte Carlo's files,
written through it, keep their bytes (``test_free_play.py``'s hashes)."""

from __future__ import annotations

import numpy as np
import pytest

from corr_cad.mechanics.drive.drive_kernel import CompiledDriveSolver
from corr_cad.mechanics.drive.drive_numerics import _forces_of, free_row

from . import test_free_play
from .test_free_play import ARCMIN, DESIGN, R, _drive


def _starts(solver, c, clearance):
    """Row ``c``'s preloaded positions and their centres' starts (the free interval's)."""
    geo = solver.geo_joined
    a = np.where(geo.loadable, geo.advance, 0.0)
    g = np.where(geo.loadable, geo.gap, -np.inf)
    sl = slice(c * R, (c + 1) * R)
    e = DESIGN.eccentricity
    rev, fwd, v0 = free_row(a[:, sl], g[:, sl], solver.n[:, sl], clearance / 2, e, True)
    idx = np.flatnonzero(~(fwd > rev))
    return idx, v0[idx]


def _row_force(solver, c, idx, v):
    """The sum of row ``c``'s roller forces with its cam centred at ``v`` (len(idx),)."""
    geo, sl = solver.geo_joined, slice(c * R, (c + 1) * R)
    h = np.full((len(idx), 2 * R), -1e300)
    gap = np.where(geo.loadable, geo.gap, -1e300)[idx][:, sl]
    h[:, sl] = gap + np.einsum("pkx,px->pk", solver.n[idx][:, sl], v)
    return np.sum(_forces_of(solver.comp.take(idx), h)[0][:, sl], axis=1)


@pytest.mark.parametrize("seed", range(1, 20))
def test_the_compiled_centre_is_the_numpy_newton_s(seed):
    solver, clearance = _drive(seed)
    for c in (0, 1):
        idx, v0 = _starts(solver, c, clearance)
        want = solver._row_centre(c, idx, v0)
        got = CompiledDriveSolver._row_centre(solver, c, idx, v0)
        held = _row_force(solver, c, idx, want) > 1e-9
        np.testing.assert_allclose(got[held], want[held], rtol=0, atol=1e-12)
        assert np.all(_row_force(solver, c, idx[~held], got[~held]) <= 1e-9)


@pytest.mark.parametrize("seed", range(20))
def test_the_compiled_solver_s_free_interval_is_the_numpy_solver_s(seed, monkeypatch):
    want = _drive(seed)[0].free_interval(solve=False)
    monkeypatch.setattr(test_free_play, "DriveSolver", CompiledDriveSolver)
    solver = _drive(seed)[0]
    assert isinstance(solver, CompiledDriveSolver)
    got = solver.free_interval(solve=False)
    for x, y in zip(got, want, strict=True):
        fin = np.isfinite(y)
        assert np.array_equal(np.isfinite(x), fin) and np.array_equal(x[~fin], y[~fin])
        assert np.all(np.abs(x[fin] - y[fin]) * ARCMIN <= 1e-9)


def test_the_seeds_hold_held_preloaded_rows_of_both_laws():
    """Enough preloaded positions where the rollers hold the cam, under each contact law,
    for the comparison to mean something."""
    count = {"nonlinear": 0, "palmgren": 0}
    for seed in range(1, 20):
        solver, clearance = _drive(seed)
        law = "palmgren" if seed % 2 else "nonlinear"
        for c in (0, 1):
            idx, v0 = _starts(solver, c, clearance)
            v = solver._row_centre(c, idx, v0)
            count[law] += int(np.sum(_row_force(solver, c, idx, v) > 1e-9))
    assert min(count.values()) >= 20, count


def test_the_drive_kernels_hold_one_specialisation_for_both_laws():
    """The warm-up's drive runs (both contact laws, with and without a clearance) leave each
    top-level drive kernel with one compiled type signature: numba compiles it once (a
    read-only broadcast view among the arguments made a second)."""
    from corr_cad.mechanics.drive import drive_centre, drive_kernel
    from corr_cad.run import warmup

    warmup._drive_kernels()
    for kernel in (drive_kernel.bearing_newton, drive_centre._centres):
        assert len(kernel.signatures) == 1, kernel.signatures


def test_the_free_play_kernels_compile_once(tmp_path):
    """From an empty cache (a fresh process: kernels loaded from a cache list no callees),
    the free interval's kernels are each compiled for one type signature (the counters
    typed as int64 from the start; a literal 0 made numba compile every callee twice)."""
    import os
    import subprocess
    import sys

    code = (
        "from corr_cad.run import warmup; warmup._free_play()\n"
        "from corr_cad.mechanics.drive import free_play as fp\n"
        "ks = (fp._width, fp._golden_centre, fp._feasible_y, fp._envelope_max, fp._free_rows)\n"
        "print([len(k.signatures) for k in ks])\n"
    )
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == "[1, 1, 1, 1, 1]", out.stdout
