"""Tolerance checks, Monte Carlo over tolerances, and tolerance allocation.

Pure numpy: no files. A tolerance is a distribution of one error kind; each
Monte Carlo sample draws every kind, perturbs the design's geometry and is
solved by the force solver (many samples per vectorised call). Work goes
through any ``concurrent.futures``-style executor (``submit`` returning
futures): a process pool by default, or a Dask ``Client``. Samples are drawn
up front from one seeded generator and split into fixed chunks, so results
are identical whichever executor runs them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from corr_cad.errors import SceneError, SolverError
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.solver import (
    _RTOL,
    BatchSolver,
    cycle_angles,
    loaded_mask,
    roller_geometry,
)

__all__ = [
    "TOLERANCE_KINDS",
    "Distribution",
    "Checks",
    "sample_metrics",
    "evaluate_checks",
    "evaluate_failure_probability",
    "draw_samples",
    "monte_carlo",
    "allocate",
    "SerialExecutor",
]

#: Error kinds a tolerance can be given for: (per roller?, unit).
TOLERANCE_KINDS = {
    "cam_radius": (False, "mm"),
    "eccentricity": (False, "mm"),
    "cam_phase": (False, "deg"),
    "roller_radius": (True, "mm"),
    "slot_angle": (True, "deg"),
}

ARCMIN_PER_RAD = 180.0 * 60.0 / math.pi


@dataclass(frozen=True)
class Distribution:
    """``normal`` (scale = sigma) or ``uniform`` (scale = half width), centred on 0."""

    kind: str
    scale: float

    def draw(self, unit: np.ndarray) -> np.ndarray:
        """Map standard draws (normal N(0,1) or uniform U(-1,1) as ``unit``) to this one."""
        return self.scale * unit


@dataclass(frozen=True)
class Checks:
    """Limits a design must meet; ``None`` means not checked."""

    max_contact_pressure: float | None = None  # MPa
    max_gear_force: float | None = None  # N
    min_loaded_rollers: int | None = None
    max_lost_motion_arcmin: float | None = None
    #: Largest allowed Monte Carlo failure probability per limit; ``None``:
    #: the Monte Carlo is reported but only the nominal design is gated.
    max_failure_probability: float | None = None

    def active(self) -> dict[str, float]:
        """The limits that are set (not the failure-probability gate)."""
        return {k: v for k, v in self.__dict__.items() if v is not None and k in CHECK_METRICS}


#: check -> (metric, sense): "max" limits bound the metric from above.
CHECK_METRICS = {
    "max_contact_pressure": ("peak_pressure", "max"),
    "max_gear_force": ("peak_gear_force", "max"),
    "min_loaded_rollers": ("min_loaded_rollers", "min"),
    "max_lost_motion_arcmin": ("lost_motion_arcmin", "max"),
}


def sample_metrics(res, n_samples: int) -> dict[str, np.ndarray]:
    """Per-sample metrics from a (sample-major) :class:`ForceResult`, each (n,)."""
    P = res.F_j.shape[0] // n_samples
    R = res.F_j.shape[1]

    def per(x):
        return x.reshape(n_samples, P, -1) if x.ndim == 2 else x.reshape(n_samples, P)

    p = np.maximum(np.maximum(res.p_cam, res.p_slot), res.p_gear)
    loaded = per(loaded_mask(res.F_j)).sum(axis=2)
    return {
        "peak_gear_force": per(res.F_n).reshape(n_samples, P * R).max(axis=1),
        "peak_pressure": per(p).reshape(n_samples, P * R).max(axis=1),
        "min_loaded_rollers": loaded.min(axis=1).astype(float),
        "lost_motion_arcmin": per(res.lost_motion).max(axis=1) * ARCMIN_PER_RAD,
    }


def evaluate_checks(values: dict[str, float], checks: Checks) -> dict[str, dict]:
    """Pass/fail and margin of every active check against metric ``values``."""
    out = {}
    for name, limit in checks.active().items():
        metric, sense = CHECK_METRICS[name]
        v = float(values[metric])
        margin = (limit - v) if sense == "max" else (v - limit)
        out[name] = {"limit": limit, "value": v, "margin": margin, "passed": bool(margin >= 0)}
    return out


def evaluate_failure_probability(failure_probability: dict[str, float], checks: Checks) -> dict:
    """The Monte Carlo gate: each limit's failure probability against the allowed one.

    Empty when ``checks.max_failure_probability`` is not set (then only the
    nominal design is gated). A limit passes when its probability of being
    broken is at most the allowed probability.
    """
    allowed = checks.max_failure_probability
    if allowed is None:
        return {}
    return {
        name: {"probability": float(p), "allowed": allowed, "passed": bool(p <= allowed)}
        for name, p in failure_probability.items()
    }


def draw_samples(
    tolerances: dict[str, Distribution], n: int, seed: int, roller_count: int
) -> dict[str, np.ndarray]:
    """Standard draws per kind (normal or uniform(-1, 1)), (n,) or (n, z+1); seeded."""
    rng = np.random.default_rng(seed)
    out = {}
    for kind in TOLERANCE_KINDS:  # fixed order: same draws whatever the dict order
        per_roller, _ = TOLERANCE_KINDS[kind]
        shape = (n, roller_count) if per_roller else (n,)
        normal = rng.standard_normal(shape)
        uniform = rng.uniform(-1.0, 1.0, shape)
        if kind in tolerances:
            out[kind] = normal if tolerances[kind].kind == "normal" else uniform
    return out


def _errors_for(base: ManufacturingErrors, tolerances, units, k: int) -> ManufacturingErrors:
    v = {kind: tolerances[kind].draw(units[kind][k]) for kind in units}
    kw = {}
    if "cam_radius" in v:
        kw["cam_radius_error"] = base.cam_radius_error + float(v["cam_radius"])
    if "eccentricity" in v:
        kw["eccentricity_error"] = base.eccentricity_error + float(v["eccentricity"])
    if "cam_phase" in v:
        kw["cam_phase_error"] = base.cam_phase_error + math.radians(float(v["cam_phase"]))
    if "roller_radius" in v:
        per = np.asarray(base.roller_radius_errors or np.zeros(len(v["roller_radius"])))
        kw["roller_radius_errors"] = tuple((per + v["roller_radius"]).tolist())
    if "slot_angle" in v:
        per = np.asarray(base.slot_angle_errors or np.zeros(len(v["slot_angle"])))
        kw["slot_angle_errors"] = tuple((per + np.radians(v["slot_angle"])).tolist())
    return replace(base, **kw)


#: Samples solved together by the numpy path: their arrays (block x positions
#: x rollers) stay in the CPU cache, which is worth ~2x over large batches.
#: Each row is solved independently, so the block size never changes a bit.
_BLOCK_ROWS = 400

#: Work (samples x crank positions) from which the compiled kernel is used.
#: Below it numba's import, cache load and (once per installation) compile
#: cost more than the kernel saves; ``corr-cad bench --study kernel`` measures
#: the crossover. The choice depends only on the work, never on the machine
#: or on whether the kernel is compiled already, so a scene always gives the
#: same bits.
KERNEL_MIN_WORK = 1_000_000


def _sample_errors(base: ManufacturingErrors, tolerances, draws, n: int, R: int):
    """Each sample's errors: ``base`` plus its draws, as arrays (n,) and (n, R).

    Roller radius: ``base.roller_radius_error`` + per-roller base + draw (mm);
    slot angle and cam phase draws are in degrees, the arrays in rad.
    """
    v = {kind: tolerances[kind].draw(u) for kind, u in draws.items()}
    cam = base.cam_radius_error + v.get("cam_radius", np.zeros(n))
    ecc = base.eccentricity_error + v.get("eccentricity", np.zeros(n))
    phase = base.cam_phase_error + np.radians(v.get("cam_phase", np.zeros(n)))
    if "roller_radius" in v:
        per = np.asarray(base.roller_radius_errors or np.zeros(R))
        dr = base.roller_radius_error + (per + v["roller_radius"])
    else:
        dr = np.tile(base.roller_errors(R), (n, 1))
    if "slot_angle" in v:
        per = np.asarray(base.slot_angle_errors or np.zeros(R))
        dl = per + np.radians(v["slot_angle"])
    else:
        dl = np.tile(base.slot_errors(R), (n, 1))
    return cam, ecc, phase, dr, dl


def _chunk_task(
    design, input_torque, angles, load_share, base, tolerances, draws, n, psi_limit, kernel
):
    """Solve one chunk of ``n`` samples (runs in a worker); ``draws``: its standard draws."""
    if kernel:
        return _kernel_chunk(
            design, input_torque, angles, load_share, base, tolerances, draws, n, psi_limit
        )
    solver = BatchSolver(
        design,
        angles,
        input_torque=input_torque,
        load_share=load_share,
        psi_contact_limit=psi_limit,
    )
    block = max(1, _BLOCK_ROWS // len(solver.angles))
    parts, ok = [], True
    for a in range(0, n, block):
        b = min(a + block, n)
        res = solver.solve([_errors_for(base, tolerances, draws, k) for k in range(a, b)])
        parts.append(sample_metrics(res, b - a))
        ok &= bool(res.success)
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}, ok


def _kernel_chunk(design, input_torque, angles, load_share, base, tolerances, draws, n, psi_limit):
    """The compiled kernel (:mod:`corr_cad.mechanics.mc_kernel`): each sample at every
    position from the nominal geometry, keeping only the metrics."""
    from corr_cad.mechanics import mc_kernel

    R = design.roller_count
    g = roller_geometry(design, angles, psi_contact_limit=psi_limit)
    if base.profile_deviation is not None:
        t_abs = angles[:, None] / design.tooth_count + np.arange(R)[None, :] * design.slot_pitch_rad
        pd = np.asarray(base.profile_deviation(t_abs), dtype=float) + 0.0 * g.psi
    else:
        pd = np.zeros_like(g.psi)
    cam, ecc, phase, dr, dl = _sample_errors(base, tolerances, draws, n, R)
    out = np.empty((n, 4))
    rel = np.empty(n)
    c = np.ascontiguousarray
    mc_kernel.solve_samples(
        c(g.psi),
        c(g.s),
        c(g.rho_n),
        c(np.abs(g.rho_s)),
        c(np.where(g.loadable, g.advance, 0.0)),
        c(g.loadable),
        c(g.k_gear),
        c(pd),
        c(cam, dtype=float),
        c(ecc, dtype=float),
        c(phase, dtype=float),
        c(dr, dtype=float),
        c(dl, dtype=float),
        float(design.eccentricity),
        float(design.link_length),
        float(design.tooth_count),
        float(design.roller_radius),
        float(design.cam_radius),
        float(design.roller_length),
        float(design.material.contact_modulus),
        load_share * float(input_torque),
        _RTOL,
        out,
        rel,
    )
    if np.any(np.isinf(rel)):
        raise SolverError(
            f"no roller can carry the moment {load_share * float(input_torque):g} N*mm "
            f"in {int(np.count_nonzero(np.isinf(rel)))} of {n} samples "
            "(all loadable rollers face the wrong way or are masked)"
        )
    metrics = {
        "peak_gear_force": out[:, 0],
        "peak_pressure": out[:, 1],
        "min_loaded_rollers": out[:, 2],
        "lost_motion_arcmin": out[:, 3] * ARCMIN_PER_RAD,
    }
    return metrics, bool(np.all(rel <= max(_RTOL, 1e-9)))


class SerialExecutor:
    """Runs tasks in this process; the ``submit`` interface of ``concurrent.futures``."""

    class _Done:
        def __init__(self, value):
            self._value = value

        def result(self):
            return self._value

    def submit(self, fn, *args):
        return self._Done(fn(*args))


def _magnitudes(units, tolerances) -> dict[str, np.ndarray]:
    out = {}
    for kind, u in units.items():
        x = tolerances[kind].draw(u)
        out[kind] = np.sqrt(np.mean(x * x, axis=1)) if x.ndim == 2 else np.abs(x)
    return out


def _spearman(a: np.ndarray, b: np.ndarray) -> float:
    ra = np.argsort(np.argsort(a)).astype(float)
    rb = np.argsort(np.argsort(b)).astype(float)
    if ra.std() == 0 or rb.std() == 0:
        return 0.0
    return float(np.corrcoef(ra, rb)[0, 1])


@dataclass
class MonteCarloResult:
    """Per-sample metrics (n,) and the drawn errors' magnitudes (n,) per kind."""

    metrics: dict[str, np.ndarray]
    magnitudes: dict[str, np.ndarray]
    success: bool

    def summary(self, checks: Checks, percentiles=(5, 50, 95, 99)) -> dict:
        out = {
            "samples": int(len(next(iter(self.metrics.values())))),
            "solver_success": self.success,
        }
        out["percentiles"] = {
            m: {f"p{q}": float(np.percentile(v, q)) for q in percentiles}
            for m, v in self.metrics.items()
        }
        fail = {}
        for name, limit in checks.active().items():
            metric, sense = CHECK_METRICS[name]
            v = self.metrics[metric]
            bad = v > limit if sense == "max" else v < limit
            fail[name] = float(np.mean(bad))
        out["failure_probability"] = fail
        sens = []
        for kind, mag in self.magnitudes.items():
            rho = {m: _spearman(mag, v) for m, v in self.metrics.items()}
            sens.append(
                {"tolerance": kind, "spearman": rho, "score": max(abs(r) for r in rho.values())}
            )
        out["sensitivity"] = sorted(sens, key=lambda d: -d["score"])
        return out


def monte_carlo(
    design: GearDesign,
    input_torque: float,
    tolerances: dict[str, Distribution],
    samples: int,
    seed: int,
    positions: int,
    *,
    load_share: float = 0.55,
    base_errors: ManufacturingErrors | None = None,
    executor=None,
    chunk: int = 50,
    progress: Callable[[int, int], None] | None = None,
    psi_contact_limit: float = math.pi,
    kernel: bool | None = None,
) -> MonteCarloResult:
    """Seeded Monte Carlo over ``tolerances``; see the module docstring.

    ``psi_contact_limit``: as in :func:`~corr_cad.mechanics.solver.solve_forces` (the
    trimmed tooth tips of an allowed undercut carry nothing).

    ``kernel``: solve with the compiled kernel (:mod:`corr_cad.mechanics.mc_kernel`,
    same results to round-off) or with the numpy solver; by default the
    kernel from :data:`KERNEL_MIN_WORK` samples x positions on.

    Each sample draws every tolerance, solves ``positions`` crank positions
    of a cycle and keeps four metrics (:func:`sample_metrics`).

    >>> from corr_cad import GearDesign, monte_carlo, Distribution, Checks
    >>> tol = {"roller_radius": Distribution("normal", 0.001)}   # sigma 1 um per roller
    >>> mc = monte_carlo(GearDesign(), 1.1e5, tol, samples=40, seed=1, positions=36)
    >>> sorted(mc.metrics)
    ['lost_motion_arcmin', 'min_loaded_rollers', 'peak_gear_force', 'peak_pressure']
    >>> s = mc.summary(Checks(max_gear_force=8000.0))
    >>> s["failure_probability"]                 # share of samples above 8000 N
    {'max_gear_force': 0.125}
    """
    unknown = [k for k in tolerances if k not in TOLERANCE_KINDS]
    if unknown:
        raise SceneError(
            f"tolerance {unknown[0]!r} is unknown; valid kinds: {', '.join(TOLERANCE_KINDS)}"
        )
    base = base_errors or ManufacturingErrors()
    angles = cycle_angles(positions)
    units = draw_samples(tolerances, samples, seed, design.roller_count)
    executor = executor or SerialExecutor()
    bounds = [(lo, min(lo + chunk, samples)) for lo in range(0, samples, chunk)]
    if kernel is None:
        kernel = samples * len(angles) >= KERNEL_MIN_WORK
    if kernel and not isinstance(executor, SerialExecutor):
        # Compile (or load from the cache) here, once, before the workers start:
        # forked workers inherit it.
        _chunk_task(
            design,
            input_torque,
            angles[:1],
            load_share,
            base,
            tolerances,
            {k: u[:1] for k, u in units.items()},
            1,
            psi_contact_limit,
            True,
        )
    futures = [
        executor.submit(
            _chunk_task,
            design,
            input_torque,
            angles,
            load_share,
            base,
            tolerances,
            {k: u[lo:hi] for k, u in units.items()},
            hi - lo,
            psi_contact_limit,
            kernel,
        )
        for lo, hi in bounds
    ]
    parts, ok = [], True
    for i, f in enumerate(futures):
        metrics, success = f.result()
        parts.append(metrics)
        ok &= bool(success)
        if progress:
            progress(bounds[i][1], samples)
    metrics = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    return MonteCarloResult(metrics, _magnitudes(units, tolerances), ok)


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

    if not checks.active():
        raise SceneError("tolerance allocation needs at least one limit in [checks]")
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
    kernel = samples * positions * expected_total() >= KERNEL_MIN_WORK

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
        )
        ok = True
        for name in checks.active():
            metric, sense = CHECK_METRICS[name]
            q = percentile if sense == "max" else 100.0 - percentile
            value = float(np.percentile(mc.metrics[metric], q))
            if not evaluate_checks({metric: value}, replace_checks(checks, name))[name]["passed"]:
                ok = False
                break
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
        return {
            "kind": kind,
            "tolerance": 0.0,
            "unit": unit,
            "distribution": distribution,
            "meaning": meaning,
            "failing_at": 0.0,
            "evaluations": evals,
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


def replace_checks(checks: Checks, keep: str) -> Checks:
    """Only the check ``keep`` active."""
    return Checks(**{k: (v if k == keep else None) for k, v in checks.__dict__.items()})
