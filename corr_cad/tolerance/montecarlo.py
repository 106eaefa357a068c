"""Monte Carlo over tolerances: seeded draws, solved in chunks on any executor.

Pure numpy: no files. A tolerance is a distribution of one error kind; each
Monte Carlo sample draws every kind, perturbs the design's geometry and is
solved by the force solver (many samples per vectorised call). Work goes
through any ``concurrent.futures``-style executor (``submit`` returning
futures): a process pool by default, or a Dask ``Client``. Samples are drawn
from one seeded generator in sample order and split into chunks, so results
are identical whichever executor runs them and however they are chunked.

Memory does not grow with the sample count but for what the summary needs
of every sample (one float per metric and tolerance): the draws are made a
chunk at a time as chunks are submitted (:class:`DrawStream`, the same
numbers as :func:`draw_samples`), at most a few chunks per worker are in
flight, and each chunk's rows go to ``sink`` as it comes back, in order.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from corr_cad.errors import SceneError, SolverError
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.row.batch import BatchSolver
from corr_cad.mechanics.row.solver import _RTOL, cycle_angles, roller_geometry
from corr_cad.tolerance.checks import ARCMIN_PER_RAD, CHECK_METRICS, Checks, sample_metrics
from corr_cad.tolerance.mc_chunks import (  # re-exported: the resource model's names
    IN_FLIGHT_PER_WORKER,
    chunk_size,
    executor_workers,
    sample_bytes,
    sample_seconds,
)

__all__ = [
    "TOLERANCE_KINDS",
    "Distribution",
    "MonteCarloResult",
    "draw_samples",
    "DrawStream",
    "chunk_size",
    "sample_seconds",
    "draw_width",
    "monte_carlo",
    "SerialExecutor",
    "COUNT_METRICS",
    "metric_percentile",
]

#: Metrics that count something (rollers): their percentiles are sample
#: values, never a fraction between two counts.
COUNT_METRICS = ("min_loaded_rollers",)
#: 0/1 flags: summarised as a probability, not as percentiles.
FLAG_METRICS = ("binds",)


def metric_percentile(values, q: float, metric: str) -> float:
    """The ``q``-th percentile of a metric's samples, as ``montecarlo_summary.json`` gives it.

    Linear interpolation between samples, except for a count
    (:data:`COUNT_METRICS`): the smallest sample with at least ``q`` % of
    the samples at or below it (``numpy`` ``inverted_cdf``), a whole number.

    >>> metric_percentile([12, 12, 13, 21, 22], 99, "min_loaded_rollers")
    22.0
    >>> metric_percentile([12, 12, 13, 21, 22], 99, "peak_gear_force")
    21.96
    """
    method = "inverted_cdf" if metric in COUNT_METRICS else "linear"
    return float(np.percentile(np.asarray(values, dtype=float), q, method=method))


#: Error kinds a tolerance can be given for: (per roller?, unit).
TOLERANCE_KINDS = {
    "cam_radius": (False, "mm"),
    "eccentricity": (False, "mm"),
    "cam_phase": (False, "deg"),
    "roller_radius": (True, "mm"),
    "slot_angle": (True, "deg"),
    # Last: the draws of the kinds above do not move. The drive model only.
    "slot_clearance": (False, "mm"),
}


@dataclass(frozen=True)
class Distribution:
    """``normal`` (scale = sigma) or ``uniform`` (scale = half width), centred on 0."""

    kind: str
    scale: float

    def draw(self, unit: np.ndarray) -> np.ndarray:
        """Map standard draws (normal N(0,1) or uniform U(-1,1) as ``unit``) to this one."""
        return self.scale * unit


def draw_samples(
    tolerances: dict[str, Distribution], n: int, seed: int, roller_count: int, stream: int = 0
) -> dict[str, np.ndarray]:
    """Standard draws per kind (normal or uniform(-1, 1)), (n,) or (n, z+1); seeded.

    ``stream`` 0 is the seed's own generator; another stream (the drive's row B,
    :mod:`corr_cad.tolerance.montecarlo_drive`) seeds ``[seed, stream]``.
    """
    rng = np.random.default_rng(seed if stream == 0 else [seed, stream])
    out = {}
    for kind in TOLERANCE_KINDS:  # fixed order: same draws whatever the dict order
        per_roller, _ = TOLERANCE_KINDS[kind]
        shape = (n, roller_count) if per_roller else (n,)
        normal = rng.standard_normal(shape)
        uniform = rng.uniform(-1.0, 1.0, shape)
        if kind in tolerances:
            out[kind] = normal if tolerances[kind].kind == "normal" else uniform
    return out


#: Standard draws skipped at a time while :class:`DrawStream` seeks a kind's block.
_SKIP_VALUES = 1 << 20


class DrawStream:
    """The standard draws of :func:`draw_samples`, a chunk of samples at a time, in order.

    :func:`draw_samples` draws, kind by kind, every sample's normal then
    uniform values from one generator. Here the generator is run once over
    those blocks (normals drawn and dropped a megavalue at a time, uniforms
    skipped by ``advance``: one 64-bit step each), keeping a generator at
    the start of each block a tolerance uses; :meth:`take` then draws the
    next samples from each. The numbers are those of :func:`draw_samples`,
    bit for bit, and the memory is that of one chunk.
    """

    def __init__(
        self, tolerances: dict[str, Distribution], n: int, seed: int, roller_count: int
    ) -> None:
        rng = np.random.default_rng(seed)
        bits = rng.bit_generator
        self._gens: dict[str, tuple[np.random.Generator, str, tuple]] = {}
        order = list(TOLERANCE_KINDS)  # draw_samples' order
        last = max((order.index(k) for k in tolerances if k in order), default=-1)
        for kind in order[: last + 1]:  # nothing drawn after the last used block is needed
            per_roller, _ = TOLERANCE_KINDS[kind]
            tail = (roller_count,) if per_roller else ()
            count = n * (roller_count if per_roller else 1)
            dist = tolerances[kind].kind if kind in tolerances else None
            if dist == "normal":
                self._gens[kind] = (self._copy(bits), "normal", tail)
            for a in range(0, count, _SKIP_VALUES):
                rng.standard_normal(min(_SKIP_VALUES, count - a))
            if dist is not None and dist != "normal":
                self._gens[kind] = (self._copy(bits), "uniform", tail)
            bits.advance(count)

    @staticmethod
    def _copy(bits) -> np.random.Generator:
        g = np.random.Generator(type(bits)())
        g.bit_generator.state = bits.state
        return g

    @property
    def kinds(self) -> list[str]:
        """The kinds drawn, in :data:`TOLERANCE_KINDS` order."""
        return list(self._gens)

    def take(self, k: int) -> dict[str, np.ndarray]:
        """The next ``k`` samples' draws, per kind (as :func:`draw_samples`)."""
        out = {}
        for kind, (g, dist, tail) in self._gens.items():
            shape = (k, *tail)
            out[kind] = (
                g.standard_normal(shape) if dist == "normal" else g.uniform(-1.0, 1.0, shape)
            )
        return out


def draw_width(tolerances, roller_count: int) -> int:
    """Standard draws a sample takes: ``z + 1`` a per-roller tolerance, else 1."""
    return sum(roller_count if TOLERANCE_KINDS[k][0] else 1 for k in tolerances)


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
    if "slot_clearance" in v:
        kw["slot_clearance"] = (base.slot_clearance or 0.0) + float(v["slot_clearance"])
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
    design,
    input_torque,
    angles,
    load_share,
    base,
    tolerances,
    draws,
    n,
    psi_limit,
    kernel,
    datasheet=None,
    grid=None,
):
    """Solve one chunk of ``n`` samples (runs in a worker); ``draws``: its standard draws.

    With ``datasheet`` (:class:`~corr_cad.tolerance.mc_datasheet.DatasheetMC`)
    the same samples' datasheet metrics are added, on the output angles ``grid``.
    """
    metrics, ok = _force_chunk(
        design, input_torque, angles, load_share, base, tolerances, draws, n, psi_limit, kernel
    )
    if datasheet is not None:
        from corr_cad.tolerance.mc_datasheet import datasheet_chunk

        errors = _sample_errors(base, tolerances, draws, n, design.roller_count)
        extra, ok_ds = datasheet_chunk(
            design, errors, n, datasheet, grid, load_share, psi_limit, base
        )
        metrics = {**metrics, **extra}
        ok = ok and ok_ds
    return metrics, ok


def _force_chunk(
    design, input_torque, angles, load_share, base, tolerances, draws, n, psi_limit, kernel
):
    """The force metrics of one chunk (the numpy solver or the compiled kernel)."""
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
    """The compiled kernel (:mod:`corr_cad.mechanics.row.mc_kernel`): each sample at every
    position from the nominal geometry, keeping only the metrics."""
    from corr_cad.mechanics.row import mc_kernel

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
    mc_kernel.solve_samples(
        *mc_kernel.kernel_inputs(g, pd, (cam, ecc, phase, dr, dl), design),
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
        "backlash_arcmin": out[:, 3] * ARCMIN_PER_RAD,
    }
    return metrics, bool(np.all(rel <= max(_RTOL, 1e-9)))


class SerialExecutor:
    """Runs tasks in this process; the ``submit`` interface of ``concurrent.futures``.

    A task runs when its result is first asked for, not at ``submit``: the
    caller collecting results in order sees each one as it is done (a
    progress line after each), as with a pool, instead of all work done
    before the first result (which once read "280h22m left").
    """

    class _Lazy:
        def __init__(self, fn, args):
            self._fn, self._args, self._done = fn, args, False

        def result(self):
            if not self._done:
                self._value = self._fn(*self._args)
                self._done, self._fn, self._args = True, None, None
            return self._value

        def done(self) -> bool:
            return self._done

    def submit(self, fn, *args):
        return self._Lazy(fn, args)


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
            m: {f"p{q}": metric_percentile(v, q, m) for q in percentiles}
            for m, v in self.metrics.items()
            if m not in FLAG_METRICS
        }
        fail = {}
        for name, limit in checks.montecarlo_active().items():
            metric, sense = CHECK_METRICS[name]
            if metric not in self.metrics:
                raise SolverError(
                    f"[checks] {name}: the Monte Carlo did not compute {metric} "
                    "(run it with the datasheet metrics)"
                )
            v = self.metrics[metric]
            bad = v > limit if sense == "max" else v < limit
            fail[name] = float(np.mean(bad))
        out["failure_probability"] = fail
        if "binds" in self.metrics:
            from corr_cad.tolerance.mc_datasheet import binding_probability

            out["binding_probability"] = binding_probability(self.metrics["binds"])
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
    chunk: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    psi_contact_limit: float = math.pi,
    kernel: bool | None = None,
    datasheet=None,
    sink: Callable[[int, dict, dict], None] | None = None,
    drive: dict | None = None,
) -> MonteCarloResult:
    """Seeded Monte Carlo over ``tolerances``; see the module docstring.

    ``psi_contact_limit``: as in :func:`~corr_cad.mechanics.row.solver.solve_forces` (the
    trimmed tooth tips of an allowed undercut carry nothing).

    ``kernel``: solve with the compiled kernel (:mod:`corr_cad.mechanics.row.mc_kernel`,
    same results to round-off) or with the numpy solver; by default the
    kernel from :data:`KERNEL_MIN_WORK` samples x positions on.

    Each sample draws every tolerance, solves ``positions`` crank positions
    of a cycle and keeps four metrics (:func:`sample_metrics`).

    ``datasheet``: a :class:`~corr_cad.tolerance.mc_datasheet.DatasheetMC`
    adds the datasheet metrics of the same samples (lost motion, rigidity,
    transmission error, binding; :mod:`corr_cad.tolerance.mc_datasheet`),
    always with the compiled kernel. The draws do not depend on it.

    ``chunk``: samples per task (by default :func:`chunk_size` for the
    executor's workers); the results do not depend on it. ``sink(lo,
    magnitudes, metrics)`` receives each chunk's rows (samples ``lo`` on) as
    they come back, in sample order: the per-sample table can be written
    while the run goes on.

    >>> from corr_cad import GearDesign, monte_carlo, Distribution, Checks
    >>> tol = {"roller_radius": Distribution("normal", 0.001)}   # sigma 1 um per roller
    >>> mc = monte_carlo(GearDesign(), 1.1e5, tol, samples=40, seed=1, positions=36)
    >>> sorted(mc.metrics)
    ['backlash_arcmin', 'min_loaded_rollers', 'peak_gear_force', 'peak_pressure']
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
    R = design.roller_count
    stream = DrawStream(tolerances, samples, seed, R)
    executor = executor or SerialExecutor()
    workers = executor_workers(executor)
    if drive is not None:
        units = draw_samples(tolerances, samples, seed, R)
        step = chunk or 50
        bounds = [(lo, min(lo + step, samples)) for lo in range(0, samples, step)]
        return _drive_monte_carlo(
            design,
            input_torque,
            tolerances,
            samples,
            seed,
            angles,
            base,
            units,
            executor,
            bounds,
            progress,
            psi_contact_limit,
            datasheet,
            drive,
            sink,
        )
    if kernel is None:
        kernel = samples * len(angles) >= KERNEL_MIN_WORK
    grid = None
    torques = 0
    if datasheet is not None:
        from corr_cad.tolerance.mc_datasheet import grid_positions

        grid = grid_positions(design, base, tolerances, datasheet.positions_per_mesh)
        torques = len(datasheet.torques()[0])
    if chunk is None:
        n_grid = 0 if grid is None else len(grid)
        per = sample_bytes(R, draw_width(tolerances, R), n_grid, torques)
        chunk = chunk_size(samples, workers, per, sample_seconds(len(angles), R, kernel, n_grid))
    args = (design, input_torque, angles, load_share, base, tolerances)
    pending: deque = deque()
    state = {"next": 0}

    def submit_next() -> None:
        lo = state["next"]
        hi = min(lo + chunk, samples)
        draws = stream.take(hi - lo)
        task = executor.submit(
            _chunk_task, *args, draws, hi - lo, psi_contact_limit, kernel, datasheet, grid
        )
        pending.append((lo, hi, _magnitudes(draws, tolerances), task))
        state["next"] = hi

    metrics: dict[str, np.ndarray] = {}
    magnitudes = {k: np.empty(samples) for k in stream.kinds}
    ok = True
    window = workers * IN_FLIGHT_PER_WORKER
    while state["next"] < samples or pending:
        while state["next"] < samples and len(pending) < window:
            submit_next()
        lo, hi, mags, task = pending.popleft()
        part, success = task.result()
        ok &= bool(success)
        if not metrics:
            metrics = {k: np.empty(samples, dtype=np.asarray(v).dtype) for k, v in part.items()}
        for k, v in part.items():
            metrics[k][lo:hi] = v
        for k, v in mags.items():
            magnitudes[k][lo:hi] = v
        if sink is not None:
            sink(lo, mags, part)
        if progress:
            progress(hi, samples)
    return MonteCarloResult(metrics, magnitudes, ok)


def _drive_monte_carlo(
    design,
    input_torque,
    tolerances,
    samples,
    seed,
    angles,
    base,
    units,
    executor,
    bounds,
    progress,
    psi_contact_limit,
    datasheet,
    drive,
    sink=None,
) -> MonteCarloResult:
    """:func:`monte_carlo` under the drive model (:mod:`corr_cad.tolerance.montecarlo_drive`);
    each chunk's rows go to ``sink`` in order, as on the paper's row."""
    from corr_cad.tolerance import mc_drive_datasheet as mdd
    from corr_cad.tolerance import montecarlo_drive as md

    tol_b = md.row_b_tolerances(tolerances)
    units_b = draw_samples(tol_b, samples, seed, design.roller_count, stream=md.ROW_B_STREAM)
    base_b = drive.get("errors_b") or base
    grid = None
    if datasheet is not None:
        grid = mdd.drive_grid(design, base, base_b, tolerances, datasheet.positions_per_mesh)
    futures = [
        executor.submit(
            mdd.drive_task,
            design,
            input_torque,
            angles,
            base,
            base_b,
            tolerances,
            {k: u[lo:hi] for k, u in units.items()},
            {k: u[lo:hi] for k, u in units_b.items()},
            hi - lo,
            psi_contact_limit,
            drive,
            _errors_for,
            datasheet,
            grid,
        )
        for lo, hi in bounds
    ]
    magnitudes = _magnitudes(units, tolerances)
    magnitudes.update({f"{k}_row_b": v for k, v in _magnitudes(units_b, tol_b).items()})
    parts, ok = [], True
    for i, f in enumerate(futures):
        metrics, success = f.result()
        parts.append(metrics)
        ok &= bool(success)
        if sink is not None:
            lo, hi = bounds[i]
            sink(lo, {k: v[lo:hi] for k, v in magnitudes.items()}, metrics)
        if progress:
            progress(bounds[i][1], samples)
    metrics = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    return MonteCarloResult(metrics, magnitudes, ok)
