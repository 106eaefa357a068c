"""The compiled Monte Carlo kernel against the numpy solver, and how it is chosen.

The numpy path (``BatchSolver``) is the one checked against the independent
reference solver and kept bit-identical to ``tests/data/montecarlo_golden.json``;
the kernel must give the same metrics to round-off on every kind of error,
including the hard cases: contacts past the validity knee, gaps that unload
half the rollers or preload all of them, masked (trimmed) tooth tips and a
gear-profile deviation.
"""

import math
import subprocess
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors, harmonic_deviation
from corr_cad.tolerance import montecarlo as tolmod
from corr_cad.tolerance.montecarlo import Distribution, monte_carlo

FOUR = {
    "roller_radius": Distribution("normal", 0.001),
    "slot_angle": Distribution("normal", 0.005),
    "cam_radius": Distribution("uniform", 0.002),
    "eccentricity": Distribution("uniform", 0.002),
}
ALL = {**FOUR, "cam_phase": Distribution("normal", 0.01)}

CASES = {
    "four_kinds": dict(tolerances=FOUR),
    "all_kinds_base_errors": dict(
        tolerances=ALL,
        base_errors=ManufacturingErrors(
            eccentricity_error=0.002,
            roller_radius_error=-0.001,
            roller_radius_errors=tuple(np.linspace(-0.002, 0.002, 26)),
            slot_angle_errors=tuple(np.radians(np.linspace(0.01, -0.01, 26))),
            cam_phase_error=math.radians(0.02),
        ),
    ),
    # 20-50 um errors: whole groups of rollers in clearance or preloaded.
    "large_errors": dict(
        tolerances={
            "roller_radius": Distribution("normal", 0.02),
            "cam_radius": Distribution("uniform", 0.05),
            "eccentricity": Distribution("normal", 0.02),
            "slot_angle": Distribution("uniform", 0.1),
        }
    ),
    # An absurd torque: contacts past the validity knee (tangent continuation).
    "overload": dict(tolerances=FOUR, input_torque=1e9),
    "profile_deviation": dict(
        tolerances=FOUR,
        base_errors=ManufacturingErrors(
            profile_deviation=harmonic_deviation([(26, 0.002, 10.0), (1, 0.003, 0.0)])
        ),
    ),
    # Trimmed tips: rollers beyond |psi| = 150 deg find no flank.
    "masked_tips": dict(tolerances=FOUR, psi_contact_limit=math.radians(150.0)),
    "reverse_torque": dict(tolerances=FOUR, input_torque=-1.1e5),
    # Zero tolerance: the nominal design, where a roller at psi = pi gets a
    # round-off force (~1e-13 N) that must not count as load.
    "zero_tolerance": dict(tolerances={"roller_radius": Distribution("normal", 0.0)}),
    # Undersized rollers: play in both directions, so backlash.
    "undersized_rollers": dict(
        tolerances={"roller_radius": Distribution("normal", 0.001)},
        base_errors=ManufacturingErrors(roller_radius_error=-0.01),
    ),
}


def _run(case: dict, kernel: bool, samples=24, positions=90, executor=None, chunk=5):
    return monte_carlo(
        GearDesign(),
        case.get("input_torque", 1.1e5),
        case["tolerances"],
        samples,
        3,
        positions,
        base_errors=case.get("base_errors"),
        psi_contact_limit=case.get("psi_contact_limit", math.pi),
        executor=executor,
        chunk=chunk,
        kernel=kernel,
    )


@pytest.mark.parametrize("name", sorted(CASES))
def test_kernel_matches_the_numpy_solver(name):
    case = CASES[name]
    a = _run(case, kernel=False)
    b = _run(case, kernel=True)
    assert a.success and b.success
    for metric, ref in a.metrics.items():
        got = b.metrics[metric]
        if metric == "min_loaded_rollers":
            np.testing.assert_array_equal(got, ref, err_msg=metric)
        else:
            np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-12, err_msg=metric)
    for kind in a.magnitudes:
        np.testing.assert_array_equal(a.magnitudes[kind], b.magnitudes[kind])


def test_kernel_cases_are_hard():
    """The hard cases really are: overload passes the knee, large errors unload rollers."""
    from corr_cad import solve_forces

    over = solve_forces(GearDesign(), CASES["overload"]["input_torque"], positions=90)
    assert not over.valid.all()
    large = _run(CASES["large_errors"], kernel=True)
    assert large.metrics["min_loaded_rollers"].min() <= 5
    assert _run(CASES["undersized_rollers"], kernel=True).metrics["backlash_arcmin"].min() > 0
    masked = _run(CASES["masked_tips"], kernel=True)
    free = _run(CASES["four_kinds"], kernel=True)
    assert not np.array_equal(masked.metrics["peak_gear_force"], free.metrics["peak_gear_force"])


def _hex(res):
    return {k: [float(x).hex() for x in v] for k, v in res.metrics.items()}


def test_kernel_identical_on_every_executor_and_chunking():
    case = CASES["all_kinds_base_errors"]
    serial = _run(case, kernel=True, samples=30, chunk=30)
    with ProcessPoolExecutor(2) as pool:
        pooled = _run(case, kernel=True, samples=30, executor=pool, chunk=7)
    assert _hex(serial) == _hex(pooled)


def test_kernel_is_chosen_by_the_work_alone(monkeypatch):
    case = CASES["four_kinds"]
    monkeypatch.setattr(tolmod, "KERNEL_MIN_WORK", 24 * 90)
    chosen = _run(case, kernel=None)
    assert _hex(chosen) == _hex(_run(case, kernel=True))
    monkeypatch.setattr(tolmod, "KERNEL_MIN_WORK", 24 * 90 + 1)
    assert _hex(_run(case, kernel=None)) == _hex(_run(case, kernel=False))


@pytest.mark.slow
def test_runs_without_monte_carlo_do_not_import_numba(tmp_path):
    """A DXF-only or forces-only run pays nothing for the kernel."""
    scene = tmp_path / "s.toml"
    scene.write_text('[load]\ninput_torque = 1.1e5\n[export]\nformats = ["dxf", "forces"]\n')
    code = (
        "import sys; from corr_cad.run.cli import main; "
        f"rc = main(['run', {str(scene)!r}, '--out', {str(tmp_path / 'out')!r}, '--quiet']); "
        "print(rc, 'numba' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split()[-2:] == ["0", "False"], out.stdout + out.stderr


@pytest.mark.parametrize("undersized", [0.0, -0.01])
def test_nested_fallback_matches_the_numpy_nested_solver(undersized):
    """The bracketed path (taken when joint Newton does not settle) on its own.

    Started from the linear-contact rotation, far left, far right and, with
    undersized rollers, at zero rotation where no roller touches (flat
    moment: only bisection can move).
    """
    from corr_cad.mechanics.row import mc_kernel
    from corr_cad.mechanics.row import solver as S

    d = GearDesign()
    err = ManufacturingErrors(
        roller_radius_error=undersized,
        roller_radius_errors=tuple(np.linspace(-0.03, 0.03, 26)) if not undersized else None,
        cam_radius_error=-0.02 if not undersized else 0.0,
    )
    angles = np.radians([0.0, 7.0, 33.0, 90.0, 181.0])
    geo = S.roller_geometry(d, angles, err)
    comp = S._Compliance(geo, d, "nonlinear")
    target = 0.55 * 1.1e5
    a = np.where(geo.loadable, geo.advance, 0.0)
    h0 = np.where(geo.loadable, geo.gap, -1e300)
    tau_np, F_np, _ = S._nested(a, geo.arm, h0, comp, target)
    R = d.roller_count
    kc = float(geo.k_cam)
    K = mc_kernel
    starts = (None, 0.0, -1e-2, 1e-1)  # linear-contact start, zero, far left, far right
    for p, start in ((p, s) for p in range(len(angles)) for s in starts):
        C = np.empty((K.FIELDS, R))
        C[K.A], C[K.H0], C[K.K0] = a[p], h0[p], comp.slope0[p]
        C[K.CJ], C[K.CN], C[K.CS] = comp.cj[p], comp.cn[p], comp.cs[p]
        C[K.WN], C[K.WS] = geo.rho_n[p], np.abs(geo.rho_s[p])
        k1, kg = geo.k_roller[p], geo.k_gear[p]
        C[K.K1], C[K.KG] = k1, kg
        for row, k2 in ((K.UKJ, kc), (K.UKN, kg), (K.UKS, 0.0)):
            C[row] = 0.99 / np.maximum(np.maximum(k1**2, k2**2), 1e-300)
        W = np.zeros((5, R))
        tau0 = start
        if start is None:
            tau0 = K._linear_tau(C, target, np.zeros(R, np.int64), np.zeros(R))
        tau, ok = K._nested(tau0, C, kc, W, target, 1e-13)
        F = W[K.F]
        assert ok
        assert tau == pytest.approx(tau_np[p], rel=1e-11), (p, start)
        np.testing.assert_allclose(F, F_np[p], rtol=1e-10, atol=1e-9)
        assert np.sum(a[p] * F) == pytest.approx(target, rel=1e-12)


def test_a_roller_at_the_edge_of_the_loaded_zone_is_not_counted():
    """At crank angle 0 roller 14 sits at psi = pi: round-off force, not load."""
    case = {"tolerances": {"roller_radius": Distribution("normal", 0.0)}}
    a = _run(case, kernel=False, samples=2, positions=1)
    b = _run(case, kernel=True, samples=2, positions=1)
    np.testing.assert_array_equal(a.metrics["min_loaded_rollers"], b.metrics["min_loaded_rollers"])
    assert b.metrics["min_loaded_rollers"][0] == 12


def test_linear_start_matches_the_numpy_linear_solution():
    """The exact linear-contact rotation (the Newton start) against solver._linear_tau."""
    from corr_cad.mechanics.row import mc_kernel as K
    from corr_cad.mechanics.row import solver as S

    d = GearDesign()
    err = ManufacturingErrors(
        roller_radius_errors=tuple(np.linspace(-0.02, 0.02, 26)[::-1] ** 3 * 1e3),
        eccentricity_error=0.01,
    )
    angles = np.radians(np.linspace(0.0, 360.0, 37))
    geo = S.roller_geometry(d, angles, err)
    comp = S._Compliance(geo, d, "nonlinear")
    a = np.where(geo.loadable, geo.advance, 0.0)
    h0 = np.where(geo.loadable, geo.gap, -1e300)
    for target in (0.55 * 1.1e5, -0.55 * 1.1e5, 1e3):
        ref = S._linear_tau(a, geo.arm, h0, comp.slope0, target)
        R = d.roller_count
        for p in range(len(angles)):
            C = np.zeros((K.FIELDS, R))
            C[K.A], C[K.H0], C[K.K0] = a[p], h0[p], comp.slope0[p]
            got = K._linear_tau(C, target, np.zeros(R, np.int64), np.zeros(R))
            assert got == pytest.approx(ref[p], rel=1e-12, abs=1e-18), (target, p)


def test_kernel_compiles_without_a_cache_location():
    """No writable cache anywhere (numba: "no locator available"): compiled in memory."""
    from corr_cad.mechanics.row import mc_kernel

    ns: dict = {}
    exec("def twice(x):\n    return 2.0 * x\n", ns)  # code without a file: numba cannot cache it
    f = mc_kernel._jit(ns["twice"])
    assert f(1.5) == 3.0


def test_a_dead_worker_is_one_line_and_exit_2(tmp_path):
    """A pool worker killed (out of memory, a crash) mid-run: one line, exit 2, folder kept."""
    scene = tmp_path / "s.toml"
    scene.write_text(
        '[load]\ninput_torque = 1.1e5\n[export]\nformats = ["montecarlo"]\n'
        "[tolerances]\ncam_radius = { uniform = 0.002 }\n"
        # enough samples for the pool (costs_montecarlo.pool_pays): fewer run here
        "[montecarlo]\nsamples = 4000\npositions = 36\n"
    )
    out = tmp_path / "out"
    out.mkdir()
    (out / "mine.txt").write_text("keep")
    code = (
        "import os, sys\n"
        "import corr_cad.tolerance.montecarlo as t\n"
        "def _chunk_task(*args):\n"
        "    os._exit(9)\n"
        "t._chunk_task = _chunk_task\n"
        "from corr_cad.run.cli import main\n"
        f"sys.exit(main(['run', {str(scene)!r}, '--out', {str(out)!r}, '--workers', '2']))\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert lines[-1].startswith("corr-cad: error: a worker process died"), r.stderr
    assert "Traceback" not in r.stderr
    assert sorted(p.name for p in out.iterdir()) == ["mine.txt"]
