"""Allocation reports progress (rate, expected total) and honours the scene's errors."""

from corr_cad import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.tolerance.allocation import allocate
from corr_cad.tolerance.checks import Checks

M0 = 1.1e5
KW = {"percentile": 90.0, "samples": 20, "seed": 2, "positions": 36}


def test_progress_counts_every_monte_carlo_and_ends_on_the_total():
    calls = []
    r = allocate(
        GearDesign(),
        M0,
        {},
        Checks(max_gear_force=5000.0),
        "roller_radius",
        progress=lambda done, expected, rate: calls.append((done, expected, rate)),
        **KW,
    )
    assert [c[0] for c in calls] == list(range(1, r["evaluations"] + 1))
    assert all(e >= d for d, e, _ in calls) and all(rate > 0 for *_, rate in calls)
    assert calls[-1][1] == r["evaluations"]  # once bracketed, the estimate is exact


def test_base_errors_are_part_of_the_allocation():
    checks = Checks(max_gear_force=5000.0)
    free = allocate(GearDesign(), M0, {}, checks, "roller_radius", **KW)
    preloaded = allocate(
        GearDesign(),
        M0,
        {},
        checks,
        "roller_radius",
        base_errors=ManufacturingErrors(cam_radius_error=0.002),
        **KW,
    )
    assert preloaded["tolerance"] < free["tolerance"]
