"""The drive's Monte Carlo solves its samples in stacked blocks with a compiled inversion
of the contact law: each sample must equal the drive solver run on it alone."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors as ME
from corr_cad.mechanics.crank.bearing import EccentricBearing
from corr_cad.mechanics.drive.drive import DriveSolver
from corr_cad.mechanics.row.solver_geometry import cycle_angles
from corr_cad.tolerance.montecarlo import Distribution, monte_carlo
from corr_cad.tolerance.montecarlo_drive import drive_chunk, drive_metrics

DESIGN = GearDesign()
NEEDLES = EccentricBearing(40, 6.0, 12.0)


def _errors(rng, R):
    return ME(
        cam_radius_error=float(rng.normal(0.0, 0.002)),
        eccentricity_error=float(rng.normal(0.0, 0.002)),
        roller_radius_errors=tuple(rng.normal(0.0, 0.002, R)),
    )


def _own_errors(base, tolerances, draws, k):
    """Sample k's errors: the draws are the errors themselves (a test's own mapping)."""
    return draws["errors"][k]


@pytest.mark.parametrize("law", ["nonlinear", "palmgren", "linear"])
@pytest.mark.parametrize("bearing", [NEEDLES, None])
def test_block_equals_the_drive_solver_sample_by_sample(law, bearing):
    R = DESIGN.roller_count
    rng = np.random.default_rng(11)
    n = 5
    ea = [_errors(rng, R) for _ in range(n)]
    eb = [_errors(rng, R) for _ in range(n)]
    ea = [replace(e, cam_phase_error=math.radians(0.05)) for e in ea]
    angles = cycle_angles(19)
    drive = {"bearing": bearing, "bearing_b": None, "contact_model": law}
    got, ok = drive_chunk(
        DESIGN,
        1.1e5,
        angles,
        None,
        None,
        {},
        {"errors": ea},
        {"errors": eb},
        n,
        math.pi,
        drive,
        _own_errors,
    )
    assert ok
    for k in range(n):
        solver = DriveSolver(
            DESIGN, angles, errors=ea[k], errors_b=eb[k], bearing=bearing, contact_model=law
        )
        want = drive_metrics(solver.result(1.1e5), solver.free_interval(), float(R))
        for name, v in want.items():
            assert got[name][k] == pytest.approx(v, rel=1e-9, abs=1e-12), (name, k)


def test_compiled_inversion_meets_the_contact_law_written_here():
    """G(F) = h with G the three Hertz approaches in series, delta(u) = (1 - sqrt(1 - k^2 u))/k
    per body (u = b^2); zero force at no overlap; dF/dh the inverse of G' by differences."""
    from corr_cad.mechanics.drive.drive_kernel import CompiledInverse

    solver = DriveSolver(DESIGN, cycle_angles(7), bearing=NEEDLES)
    comp = solver.comp
    inv = CompiledInverse(comp, solver.n.shape[:2])
    geo = solver.geo_joined
    h = np.where(geo.loadable, 2e-3, -1e-3)
    F, k = inv(h, h / comp.slope0)
    length, E = DESIGN.roller_length, DESIGN.material.contact_modulus
    k1 = geo.k_roller

    def delta(u, ka, kb):
        # a flat body (k = 0) adds nothing: (1 - sqrt(1 - k^2 u)) / k -> k u / 2 -> 0
        one = np.where(ka != 0, (1 - np.sqrt(1 - ka * ka * u)) / np.where(ka != 0, ka, 1), 0.0)
        two = np.where(kb != 0, (1 - np.sqrt(1 - kb * kb * u)) / np.where(kb != 0, kb, 1), 0.0)
        return one + two

    def G(F):
        # b^2 = 4 F / (pi l E' (k1 + k2)) per contact force: half_width_sq_per_force written out
        def b2(f, ka, kb):
            return 4.0 * f / (math.pi * length * E * (ka + kb))

        wn, ws = geo.rho_n, np.abs(geo.rho_s)
        return (
            delta(b2(F, k1, geo.k_cam), k1, geo.k_cam)
            + wn * delta(b2(wn * F, k1, geo.k_gear), k1, geo.k_gear)
            + ws * delta(b2(ws * F, k1, 0.0), k1, 0.0)
        )

    pos = h > 0
    assert np.all(F[~pos] == 0.0) and np.all(k[~pos] == 0.0)
    # 1 - sqrt(1 - k^2 u) cancels (k^2 u ~ 1e-7): this form keeps ~1e-9 of its digits
    np.testing.assert_allclose(G(F)[pos], h[pos], rtol=1e-8)
    dF = 1e-3 * F  # central differences: error ~1e-6 of the slope, well above round-off
    slope = (G(F + dF) - G(F - dF)) / (2 * dF)
    np.testing.assert_allclose(k[pos], 1.0 / slope[pos], rtol=1e-5)


def test_monte_carlo_on_the_drive_is_seeded_and_independent_of_chunking():
    tol = {"roller_radius": Distribution("normal", 0.001)}
    mc = {"bearing": NEEDLES, "contact_model": "nonlinear"}
    one = monte_carlo(DESIGN, 1.1e5, tol, 6, 3, 12, drive=mc, chunk=6)
    two = monte_carlo(DESIGN, 1.1e5, tol, 6, 3, 12, drive=mc, chunk=2)
    assert one.success
    for name, v in one.metrics.items():
        np.testing.assert_array_equal(v, two.metrics[name])


def test_stacked_geometry_is_each_samples_drive_geometry_bit_for_bit():
    from corr_cad.mechanics.drive.drive import drive_geometry, row_errors
    from corr_cad.tolerance.montecarlo_drive import stacked_geometry

    R = DESIGN.roller_count
    rng = np.random.default_rng(3)

    def errors():
        return replace(
            _errors(rng, R),
            slot_clearance=float(abs(rng.normal(0.0, 0.003))),
            cam_phase_error=math.radians(float(rng.normal(0.0, 0.05))),
            slot_angle_errors=tuple(rng.normal(0.0, 1e-4, R)),
        )

    pairs = [(errors(), errors()) for _ in range(3)] + [(ME(), ME())]
    angles = cycle_angles(17)
    stacked = stacked_geometry(DESIGN, angles, pairs, 2.5)
    for k, (ea, eb) in enumerate(pairs):
        alone = drive_geometry(DESIGN, angles, *row_errors(ea, eb), (), 2.5)
        for big, g in zip(stacked, alone, strict=True):
            for name in g.__dataclass_fields__:
                got = getattr(big, name)[17 * k : 17 * (k + 1)]
                np.testing.assert_array_equal(got, np.broadcast_to(getattr(g, name), got.shape))


def test_numpy_inversion_stops_each_roller_as_the_compiled_one():
    """The drive's numpy inversion of the paper's law iterates each loaded roller on its own
    until its step is below 1e-15 of its force, from the same start as the compiled one:
    both give the same forces and stiffnesses to round-off, and zero where unloaded."""
    from corr_cad.mechanics.drive.drive_kernel import CompiledInverse
    from corr_cad.mechanics.drive.drive_numerics import _invert_convex

    solver = DriveSolver(DESIGN, cycle_angles(11), bearing=NEEDLES)
    comp = solver.comp
    rng = np.random.default_rng(5)
    h = np.where(solver.geo_joined.loadable, rng.uniform(-2e-3, 4e-3, comp.slope0.shape), -1.0)
    start = np.maximum(h, 0.0) / comp.slope0
    F, k = _invert_convex(comp, h, start)
    Fc, kc = CompiledInverse(comp, h.shape)(h, start)
    assert np.all((F > 0) == (h > 0)) and np.all(k[h <= 0] == 0.0)
    np.testing.assert_allclose(F, Fc, rtol=1e-14, atol=0)
    np.testing.assert_allclose(k, kc, rtol=1e-13, atol=0)
