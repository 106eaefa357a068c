"""Tolerance allocation: the largest symmetric tolerance of one kind that keeps the checks.

A bracketing search over seeded Monte Carlos with common random numbers
(:func:`~corr_cad.tolerance.montecarlo.monte_carlo`), so the metrics move
monotonically with the tolerance. Pure numpy.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from corr_cad.errors import SceneError
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.tolerance import montecarlo as _mc
from corr_cad.tolerance.checks import CHECK_METRICS, Checks, evaluate_checks, replace_checks
from corr_cad.tolerance.montecarlo import TOLERANCE_KINDS, Distribution, monte_carlo

__all__ = ["allocate"]


def allocate(
    design: GearDesign,
    input_torque: float,
    tolerances: dict[str, Distribution],
    checks: Checks,
    kind: str,
    *,
    percentile: float = 95.0,
    samples: int = 200,
    seed: int = 1,
    positions: int = 72,
    load_share: float = 0.55,
    executor=None,
    rel_precision: float = 0.02,
    base_errors: ManufacturingErrors | None = None,
    psi_contact_limit: float = math.pi,
    progress: Callable[[int, int, float], None] | None = None,
    distribution: str | None = None,
    datasheet=None,
    drive: dict | None = None,
) -> dict:
    """Largest symmetric tolerance ``T`` of ``kind`` that keeps the checks.

    ``T`` is in the terms the tolerance was given in: a sigma when
    ``tolerances[kind]`` is normal, a uniform half-width (+-T) when it is
    uniform or not given; ``distribution`` ("normal" or "uniform")
    overrides. The result says which (``distribution``, ``meaning``).
    The other kinds keep their given distributions. The same standard draws
    are reused for every ``T`` (common random numbers), so the metrics move
    monotonically with ``T`` and a bracketing search applies: double ``T``
    until a check fails, then bisect (geometrically) to ``rel_precision``.
    Returns ``{"kind", "tolerance", "unit", "failing_at", "evaluations"}``;
    ``tolerance`` is 0 when even a perfect part fails.

    ``drive``: the two-row drive's Monte Carlo
    (:func:`~corr_cad.tolerance.montecarlo.monte_carlo`'s argument; force metrics).

    ``progress(done, expected, samples_per_s)`` is called after each Monte
    Carlo: evaluations done, the expected total (the bisection's remaining
    steps are known once the root is bracketed; before that, a doubling
    more), and the measured sample rate.

    Returns ``{"kind", "tolerance", "unit", "distribution", "meaning",
    "failing_at", "evaluations"}``; ``tolerance`` is 0 when even a perfect
    part fails.

    >>> from corr_cad import GearDesign, allocate, Checks
    >>> a = allocate(GearDesign(), 1.1e5, {}, Checks(max_gear_force=8000.0), "roller_radius",
    ...              samples=20, positions=36)
    >>> a["meaning"], round(a["tolerance"] * 1000, 2), a["unit"]   # +-2.16 um keeps p95 < 8 kN
    ('uniform half-width', 2.16, 'mm')
    """
    import time

    t_start = time.perf_counter()
    state = {"lo": 0.0, "hi": None}

    def expected_total() -> int:
        lo, hi = state["lo"], state["hi"]
        bisect = 0
        width = (hi - lo) if hi is not None else None
        if width is not None:
            while width > rel_precision * hi:
                width *= 0.5
                bisect += 1
            return evals + bisect
        return evals + 1 + max(1, math.ceil(math.log2(1.0 / rel_precision)))

    binding_limit = checks.max_binding_probability
    if not checks.active() and binding_limit is None:
        raise SceneError("tolerance allocation needs at least one limit in [checks]")
    if datasheet is None and (checks.datasheet_active() or binding_limit is not None):
        what = next(iter(checks.datasheet_active()), "max_binding_probability")
        raise SceneError(
            f"tolerance allocation on {what} needs the Monte Carlo's datasheet metrics "
            "(pass datasheet=DatasheetMC(...))"
        )
    evals = 0

    if kind not in TOLERANCE_KINDS:
        raise SceneError(
            f"tolerance {kind!r} is unknown; valid kinds: {', '.join(TOLERANCE_KINDS)}"
        )

    if distribution is None:
        distribution = tolerances[kind].kind if kind in tolerances else "uniform"
    if distribution not in ("normal", "uniform"):
        raise SceneError(f"distribution {distribution!r} must be normal or uniform")
    meaning = "sigma" if distribution == "normal" else "uniform half-width"
    # The kernel pays for itself on the whole allocation's work (all its Monte
    # Carlos), decided once so that every evaluation takes the same path.
    # Read through the module, so that the threshold has one home.
    kernel = samples * positions * expected_total() >= _mc.KERNEL_MIN_WORK

    def passes(T: float) -> bool:
        nonlocal evals
        evals += 1
        tol = dict(tolerances)
        tol[kind] = Distribution(distribution, T)
        mc = monte_carlo(
            design,
            input_torque,
            tol,
            samples,
            seed,
            positions,
            load_share=load_share,
            executor=executor,
            base_errors=base_errors,
            psi_contact_limit=psi_contact_limit,
            kernel=kernel,
            datasheet=datasheet,
            drive=drive,
        )
        failing = []
        if binding_limit is not None and float(np.mean(mc.metrics["binds"])) > binding_limit:
            failing.append("max_binding_probability")
        for name in checks.montecarlo_active():
            metric, sense = CHECK_METRICS[name]
            q = percentile if sense == "max" else 100.0 - percentile
            value = float(np.percentile(mc.metrics[metric], q))
            if not evaluate_checks({metric: value}, replace_checks(checks, name))[name]["passed"]:
                failing.append(name)
                if T > 0:  # at T = 0 every failing check is named (the zero explained)
                    break
        ok = not failing
        state["failing"] = failing
        if ok:
            state["lo"] = T
        elif T > 0:
            state["hi"] = T
        if progress:
            rate = evals * samples / max(time.perf_counter() - t_start, 1e-9)
            done = not ok and T == 0
            progress(evals, evals if done else max(expected_total(), evals), rate)
        return ok

    unit = TOLERANCE_KINDS[kind][1]
    if not passes(0.0):
        names = ", ".join(state["failing"])
        others = sorted(k for k in tolerances if k != kind)
        if others:
            why = (
                f"with {', '.join(others)} as given and {kind} perfect, {names} already "
                f"fail(s) at the {percentile:g}th percentile; no {kind} tolerance can pass"
            )
        else:
            why = f"the nominal design already fails {names}; no tolerance can pass"
        return {
            "kind": kind,
            "tolerance": 0.0,
            "unit": unit,
            "distribution": distribution,
            "meaning": meaning,
            "failing_at": 0.0,
            "evaluations": evals,
            "why_zero": why,
        }

    def answer(tolerance: float, failing_at: float | None) -> dict:
        return {
            "kind": kind,
            "tolerance": tolerance,
            "unit": unit,
            "distribution": distribution,
            "meaning": meaning,
            "failing_at": failing_at,
            "evaluations": evals,
        }

    lo, hi = 0.0, (1e-3 if unit == "mm" else 1e-2)
    cap = 0.5 * design.roller_radius if unit == "mm" else 5.0
    while passes(hi):
        lo, hi = hi, 2.0 * hi
        if hi > cap:
            return answer(lo, None)
    while hi - lo > rel_precision * hi:
        mid = math.sqrt(lo * hi) if lo > 0 else 0.5 * hi
        if passes(mid):
            lo = mid
        else:
            hi = mid
    return answer(lo, hi)
