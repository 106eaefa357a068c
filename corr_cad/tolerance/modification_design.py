"""Design a profile modification to targets under the tolerance scatter (issue 20, item 3).

Search space (``family``): ``equidistant`` (``d_eq`` on a grid) or
``equidistant+shift`` (a grid of ``d_eq`` x ``d_sh``). Targets: the backlash
at a percentile (``backlash_percentile``, default p95) at most
``target_backlash_arcmin``, and the binding probability at most
``max_binding_probability``. Objective at rated torque: ``peak_pressure``
(p95, smallest) or ``loaded_rollers`` (p5 of the fewest loaded rollers,
largest).

How, and why it is fast:

1. The tolerance samples are drawn once (the Monte Carlo's seeded draws,
   :func:`~corr_cad.tolerance.montecarlo.draw_samples`) and their chain gaps
   built once (:class:`~corr_cad.mechanics.row.batch.BatchSolver`).
2. A modification adds ``-rho_n c(psi)`` to every gap (``c`` the exact flank
   clearance, :func:`~corr_cad.geometry.modification.flank_clearance`), so
   each candidate costs one projection and array arithmetic, no force solve:
   backlash (the free rotation) and binding (:func:`chain_interference`)
   need only the gaps.
3. Only the candidates that meet both targets are solved for forces (the
   Monte Carlo of :func:`~corr_cad.tolerance.montecarlo.monte_carlo` with the
   modification as the base gap; every executor, bit-identical), at most
   ``force_candidates`` of them, spread over the feasible backlash range.

Sampling error: a probability ``p`` from ``n`` samples has standard error
``sqrt(p (1 - p) / n)``; a percentile ``q`` is given with the order
statistics at ranks ``n q -+ sqrt(n q (1 - q))`` (about a 68 % interval).

The binding evaluation is one function, :func:`chain_interference`: the
Monte Carlo binding metric (``mechanics/binding.py``, another branch) can
replace it there.

Under the two-row drive (``drive``: ``[solver] model = "drive"``) both
rings carry the same modification (ring B is ring A turned by ``pi / z``, the
same part), so a candidate's clearance ``c(psi)`` is taken off each row's gaps
at that row's own roll angles (row B's at ``phi + pi``). The samples are the
drive's Monte Carlo's (:mod:`corr_cad.tolerance.montecarlo_drive`: row A and
the frame from the seed's draws, row B's own tolerances from its second
stream), and :class:`DriveGapMetrics` gives per sample:

* **backlash**: the drive's free rotation, the largest over the positions of
  the width of :meth:`DriveSolver.free_interval
  <corr_cad.mechanics.drive.drive.DriveSolver.free_interval>` (the intersection of
  both rows' free intervals, each widened by its cam bearing's clearance),
  over ``z + 1``, in arcmin; 0 where none is left;
* **binding**: a position binds where no crank rotation leaves every roller
  of both rows (the slots shared, their fit ``slot_clearance`` in the gaps)
  within ``BINDING_EPS_MM`` of contact: with the cams fixed or on bearings
  without clearance, :func:`chain_interference`'s test over the ``2 (z + 1)``
  rollers, as selective assembly judges the drive; with a bearing clearance
  each cam may also shift within ``Pd / 2`` (each row's free interval of its
  gaps less that allowance, :func:`~corr_cad.mechanics.drive.drive_numerics.free_row`,
  and their intersection).

The force candidates are solved by the drive's Monte Carlo (its contact law
and bearings; ``peak_pressure`` and ``min_loaded_rollers`` over both rows),
``transmission_error`` by the drive's datasheet.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from corr_cad.errors import CorrCadError
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.geometry.modification import (
    Modification,
    flank_clearance,
    modification_gap,
    modified_profile,
    with_modification,
)
from corr_cad.mechanics.drive.drive import DriveSolver
from corr_cad.mechanics.drive.drive_numerics import free_row
from corr_cad.mechanics.row.batch import BatchSolver
from corr_cad.mechanics.row.solver_geometry import cycle_angles
from corr_cad.mechanics.row.windup import ARCMIN_PER_RAD
from corr_cad.tolerance.montecarlo import _errors_for, draw_samples, monte_carlo
from corr_cad.tolerance.montecarlo_drive import ROW_B_STREAM, row_b_tolerances, stacked_geometry

__all__ = [
    "FAMILIES",
    "OBJECTIVES",
    "chain_interference",
    "DriveGapMetrics",
    "gap_metrics",
    "percentile_with_error",
    "design_modification",
]

FAMILIES = ("equidistant", "equidistant+shift", "free")
OBJECTIVES = ("peak_pressure", "loaded_rollers", "transmission_error")
#: ``free``: a symmetric normal curve through control points at these roll angles (deg),
#: a periodic cubic spline (C2) as a ``normal_table``.
FREE_CONTROL_PSI_DEG = (0.0, 60.0, 120.0, 180.0)
#: Interference (mm) below this is exact contact, not binding.
BINDING_EPS_MM = 1e-9


def chain_interference(gap: np.ndarray, advance: np.ndarray, loadable: np.ndarray) -> np.ndarray:
    """``min_tau max_i (g_i + a_i tau)`` per row (M,), mm: > 0 binds (see tolerance.assembly)."""
    g = np.where(loadable, gap, -np.inf)
    a = np.where(loadable, advance, 0.0)
    out = np.max(np.where(a == 0.0, g, -np.inf), axis=1)
    up, dn = a > 0, a < 0
    ai, gi = a[:, :, None], g[:, :, None]
    aj, gj = a[:, None, :], g[:, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        cross = (ai * gj - aj * gi) / (ai - aj)
    cross = np.where(up[:, :, None] & dn[:, None, :], cross, -np.inf)
    return np.maximum(out, cross.max(axis=(1, 2)))


def _free_rotation(gap: np.ndarray, advance: np.ndarray, loadable: np.ndarray) -> np.ndarray:
    """Free cam rotation per row (M,), rad: ``fwd - rev`` where positive, else 0."""
    a = np.where(loadable, advance, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -gap / a
    fwd = np.min(np.where(a > 0, t, np.inf), axis=1)
    rev = np.max(np.where(a < 0, t, -np.inf), axis=1)
    return np.maximum(fwd - rev, 0.0)


def gap_metrics(geo, n: int, design: GearDesign, clearance: np.ndarray | None = None):
    """Per sample: backlash (arcmin, max over the positions) and binding (bool).

    ``geo``: the stacked sample geometry (n P, R); ``clearance`` (P, R) mm: a
    modification's flank clearance at each nominal roller position.
    """
    gap = geo.gap
    if clearance is not None:  # rows are sample-major: sample k holds rows k P .. k P + P - 1
        gap = gap - geo.rho_n * np.tile(clearance, (n, 1))
    free = _free_rotation(gap, geo.advance, geo.loadable) / design.roller_count
    inter = chain_interference(gap, geo.advance, geo.loadable)
    backlash = free.reshape(n, -1).max(axis=1) * ARCMIN_PER_RAD
    binds = inter.reshape(n, -1).max(axis=1) > BINDING_EPS_MM
    return backlash, binds


class DriveGapMetrics:
    """Backlash and binding of the drive's tolerance samples under a candidate's clearance.

    ``drive``: ``errors_b`` (row B's base errors, None: ``base``'s), ``bearing``,
    ``bearing_b`` and ``contact_model`` (the Monte Carlo's ``drive`` argument). The
    samples' drive is built once; a candidate changes its gaps only.
    """

    def __init__(
        self,
        design: GearDesign,
        tolerances: dict,
        samples: int,
        seed: int,
        angles: np.ndarray,
        base: ManufacturingErrors,
        drive: dict,
        psi_contact_limit: float,
    ):
        R = design.roller_count
        tol_b = row_b_tolerances(tolerances)
        units = draw_samples(tolerances, samples, seed, R)
        units_b = draw_samples(tol_b, samples, seed, R, stream=ROW_B_STREAM)
        base_b = drive.get("errors_b") or base
        pairs = [
            (_errors_for(base, tolerances, units, k), _errors_for(base_b, tol_b, units_b, k))
            for k in range(samples)
        ]
        angles = np.asarray(angles, dtype=float)
        self.solver = DriveSolver(
            design,
            np.tile(angles, samples),
            geometry=stacked_geometry(design, angles, pairs, psi_contact_limit),
            bearing=drive.get("bearing"),
            bearing_b=drive.get("bearing_b"),
            contact_model=drive.get("contact_model", "nonlinear"),
        )
        self.design, self.samples = design, samples
        #: The nominal roll angles (P, 2 R), row A's rollers then row B's: where a
        #: candidate's clearance is taken.
        self.psi = self.solver.geo_joined.psi[: len(angles)]

    def __call__(self, clearance: np.ndarray | None = None):
        """Per sample: backlash (arcmin) and binding (bool); ``clearance``: the flank
        clearance (P, 2 R) mm at :attr:`psi` (None: the unmodified rings)."""
        n, R = self.samples, self.design.roller_count
        solver = copy.copy(self.solver)  # the samples' drive with the candidate's gaps
        geo = solver.geo_joined
        if clearance is not None:
            geo = replace(geo, gap=geo.gap - geo.rho_n * np.tile(clearance, (n, 1)))
            solver.geo_joined = geo
        rev, fwd = solver.free_interval(solve=False)
        free = np.where(fwd > rev, fwd - rev, 0.0) / R
        backlash = free.reshape(n, -1).max(axis=1) * ARCMIN_PER_RAD
        return backlash, self._binds(solver, geo).reshape(n, -1).any(axis=1)

    def _binds(self, solver: DriveSolver, geo) -> np.ndarray:
        """Where no crank rotation, each cam shifting within its bearing's clearance (none
        without bearings), leaves every roller of both rows within ``BINDING_EPS_MM`` of
        contact (bool, (n P,)): each row's free interval of its gaps less that allowance,
        intersected (for rigid cams :func:`chain_interference`'s test in its interval
        form, ``O(z)`` a position where the crossings cost ``O(z^2)``)."""
        R, e = self.design.roller_count, self.design.eccentricity
        a = np.where(geo.loadable, geo.advance, 0.0)
        g = np.where(geo.loadable, geo.gap - BINDING_EPS_MM, -np.inf)
        revs, fwds = [], []
        binds = np.zeros(len(a), dtype=bool)
        for c, sl in enumerate((slice(0, R), slice(R, 2 * R))):
            b = solver.bearings[c]
            half = 0.5 * b.diametral_clearance if b is not None else 0.0
            rev, fwd = free_row(a[:, sl], g[:, sl], solver.n[:, sl], half, e)
            if half == 0.0:  # a roller that the crank does not move binds on its own
                binds |= np.any((a[:, sl] == 0.0) & (g[:, sl] > 0.0), axis=1)
            revs.append(rev)
            fwds.append(fwd)
        return binds | ~(np.minimum(*fwds) >= np.maximum(*revs))


def percentile_with_error(values: np.ndarray, q: float) -> dict:
    """The ``q`` % percentile and its order-statistics interval (about 68 %)."""
    v = np.sort(np.asarray(values, dtype=float))
    n = v.size
    p = q / 100.0
    half = math.sqrt(n * p * (1.0 - p))
    lo = int(min(max(math.floor(n * p - half), 0), n - 1))
    hi = int(min(max(math.ceil(n * p + half), 0), n - 1))
    return {"value": float(np.percentile(v, q)), "range": [float(v[lo]), float(v[hi])]}


def _grid(family: str, equidistant_mm: tuple, shift_mm: tuple) -> list[dict]:
    """The candidates of a family, as ``modification.json`` rows start."""
    eqs = [float(v) for v in np.linspace(*equidistant_mm[:2], int(equidistant_mm[2]))]
    if family == "free":
        import itertools

        return [
            {"equidistant_mm": 0.0, "shift_mm": 0.0, "normal_psi_deg": list(FREE_CONTROL_PSI_DEG),
             "normal_mm": list(v)}
            for v in itertools.product(eqs, repeat=len(FREE_CONTROL_PSI_DEG))
        ]  # fmt: skip
    shs = np.linspace(*shift_mm[:2], int(shift_mm[2])) if family == "equidistant+shift" else [0.0]
    return [{"equidistant_mm": a, "shift_mm": float(b)} for a in eqs for b in shs]


def _modification(row: dict) -> Modification:
    """The :class:`Modification` of a candidate row."""
    table = None
    if "normal_mm" in row:
        from corr_cad.geometry.modification import NormalTable

        table = NormalTable(tuple(row["normal_psi_deg"]), tuple(row["normal_mm"]), "free")
    return Modification(row["equidistant_mm"], row["shift_mm"], table)


def _probability(x: np.ndarray) -> dict:
    p = float(np.mean(x))
    return {"value": p, "standard_error": math.sqrt(p * (1.0 - p) / x.size)}


def _modified_drive(drive: dict | None, gap) -> dict | None:
    """The Monte Carlo's ``drive`` argument with the modification in row B's errors too."""
    if drive is None:
        return None
    eb = drive.get("errors_b")
    return {**drive, "errors_b": None if eb is None else with_modification(eb, gap)}


def _datasheet_drive(drive: dict | None, gap) -> dict:
    """The datasheet's keyword arguments of the drive (none for the paper's row)."""
    if drive is None:
        return {}
    d = _modified_drive(drive, gap)
    return {
        "contact_model": d.get("contact_model", "nonlinear"),
        "drive": {
            k: d.get(k) for k in ("errors_b", "bearing", "bearing_b", "crank", "bodies") if k in d
        },
    }


def design_modification(
    design: GearDesign,
    tolerances: dict,
    *,
    family: str,
    objective: str,
    target_backlash_arcmin: float,
    max_binding_probability: float,
    crank_moment: float,
    equidistant_mm: tuple[float, float, int],
    shift_mm: tuple[float, float, int],
    backlash_percentile: float = 95.0,
    samples: int = 200,
    seed: int = 1,
    positions: int = 64,
    force_candidates: int = 5,
    base_errors: ManufacturingErrors | None = None,
    load_share: float = 0.55,
    psi_contact_limit: float = math.pi,
    executor=None,
    progress: Callable[[int, int], None] | None = None,
    datasheet_spec=None,
    drive: dict | None = None,
) -> dict:
    """Search the family's grid; the ``modification.json`` content (see the module docstring).

    ``free``: each control point of :data:`FREE_CONTROL_PSI_DEG` takes the
    values of ``equidistant_mm``'s grid. ``transmission_error`` needs
    ``datasheet_spec`` (the nominal transmission error of each force-solved
    candidate, no scatter). ``drive``: the two-row drive (the Monte Carlo's ``drive``
    argument: ``errors_b``, ``bearing``, ``bearing_b``, ``contact_model``; see the module
    docstring); ``load_share`` is then unused.
    """
    base = base_errors or ManufacturingErrors()
    angles = cycle_angles(positions)
    if drive is None:
        units = draw_samples(tolerances, samples, seed, design.roller_count)
        solver = BatchSolver(design, angles, input_torque=crank_moment, load_share=load_share)
        geo = solver.geometry([_errors_for(base, tolerances, units, k) for k in range(samples)])
        psi = solver.nominal.psi
    else:
        gaps = DriveGapMetrics(
            design, tolerances, samples, seed, angles, base, drive, psi_contact_limit
        )
        psi = gaps.psi
    grid = _grid(family, equidistant_mm, shift_mm)
    rows = []
    for k, row in enumerate(grid):
        row = dict(row)
        try:
            curve = modified_profile(design, _modification(row))
        except CorrCadError as exc:
            rows.append({**row, "valid": False, "why": str(exc)})
            continue
        c = flank_clearance(design, curve, psi.ravel()).reshape(psi.shape)
        if drive is None:
            backlash, binds = gap_metrics(geo, samples, design, c)
        else:
            backlash, binds = gaps(c)
        bl = {
            f"p{q}": percentile_with_error(backlash, q)
            for q in sorted({50, 95, 99, int(backlash_percentile)})
        }
        row.update(
            valid=True,
            backlash_arcmin=bl,
            binding_probability=_probability(binds),
        )
        row["meets_backlash"] = (
            bl[f"p{int(backlash_percentile)}"]["value"] <= target_backlash_arcmin
        )
        row["meets_binding"] = row["binding_probability"]["value"] <= max_binding_probability
        rows.append(row)
        if progress:
            progress(k + 1, len(grid))
    key = f"p{int(backlash_percentile)}"
    feasible = [r for r in rows if r.get("valid") and r["meets_backlash"] and r["meets_binding"]]
    chosen, failed = None, None
    if feasible:
        feasible.sort(key=lambda r: r["backlash_arcmin"][key]["value"])
        pick = np.unique(
            np.linspace(0, len(feasible) - 1, min(force_candidates, len(feasible)))
            .round()
            .astype(int)
        )
        for i in pick:
            r = feasible[int(i)]
            gap = modification_gap(design, modified_profile(design, _modification(r)))
            mc = monte_carlo(
                design,
                crank_moment,
                tolerances,
                samples,
                seed,
                positions,
                load_share=load_share,
                base_errors=with_modification(base, gap),
                executor=executor,
                psi_contact_limit=psi_contact_limit,
                drive=_modified_drive(drive, gap),
            )
            r["peak_pressure_MPa"] = {
                f"p{q}": percentile_with_error(mc.metrics["peak_pressure"], q) for q in (50, 95, 99)
            }
            r["min_loaded_rollers"] = {
                f"p{q}": percentile_with_error(mc.metrics["min_loaded_rollers"], q)
                for q in (1, 5, 50)
            }
            r["force_solved"] = True
            if objective == "transmission_error":
                from corr_cad.mechanics.datasheet import datasheet

                ds = datasheet(
                    design,
                    datasheet_spec,
                    errors=with_modification(base, gap),
                    load_share=load_share,
                    psi_contact_limit=psi_contact_limit,
                    **_datasheet_drive(drive, gap),
                )
                te = ds.transmission_error_peak_to_peak()
                r["transmission_error_arcsec_nominal"] = max(te.values())
        solved = [r for r in feasible if r.get("force_solved")]
        if objective == "transmission_error":
            chosen = min(solved, key=lambda r: r["transmission_error_arcsec_nominal"])
        elif objective == "peak_pressure":
            chosen = min(solved, key=lambda r: r["peak_pressure_MPa"]["p95"]["value"])
        else:
            chosen = max(
                solved,
                key=lambda r: (
                    r["min_loaded_rollers"]["p5"]["value"],
                    -r["peak_pressure_MPa"]["p95"]["value"],
                ),
            )
    else:
        valid = [r for r in rows if r.get("valid")]
        free = [r for r in valid if r["meets_binding"]]
        if not free:
            best = min(valid, key=lambda r: r["binding_probability"]["value"])
            failed = (
                f"max_binding_probability = {max_binding_probability:g} is the binding target: the "
                f"best candidate binds with probability {best['binding_probability']['value']:.4g}"
            )
        else:
            best = min(free, key=lambda r: r["backlash_arcmin"][key]["value"])
            failed = (
                f"target_backlash_arcmin = {target_backlash_arcmin:g} is the binding target: the "
                f"smallest {key} backlash without exceeding the binding probability is "
                f"{best['backlash_arcmin'][key]['value']:.4g} arcmin"
            )
        chosen = best
    return {
        "family": family,
        "objective": objective,
        "targets": {
            "target_backlash_arcmin": target_backlash_arcmin,
            "backlash_percentile": backlash_percentile,
            "max_binding_probability": max_binding_probability,
        },
        "met": failed is None,
        "failed": failed,
        "chosen": chosen,
        "samples": samples,
        "seed": seed,
        "positions": positions,
        "crank_moment_Nmm": crank_moment,
        "candidates": rows,
        "sampling_error": "probability: standard error sqrt(p (1 - p) / n); percentile: "
        "order statistics at ranks n q -+ sqrt(n q (1 - q)) (about 68 %)",
    }
