"""Datasheet figures of the drive: what a precision reducer is bought on.

Every figure is read off the windup ``theta(T, x)`` of
:mod:`corr_cad.mechanics.row.windup` (output torque ``T``, crank locked, ring
fixed, output position ``x``), the way a test bench reads it off the
hysteresis curve (torque cycled ``0 -> +T_R -> 0 -> -T_R -> 0``):

==========================  ==================================================================
figure                      definition, at each position
==========================  ==================================================================
backlash                    ``theta(0+) - theta(0-)``: the free rotation, every clearance open
lost motion                 ``theta(+b T_R) - theta(-b T_R)``, ``b = lost_motion_band`` (3 %)
torsional rigidity          ``(T_2 - T_1) / (theta(T_2) - theta(T_1))`` on each branch,
                            ``[T_1, T_2] = rigidity_range T_R`` (``[0.5, 1.0]``), N*m/arcmin
K1, K2, K3                  slopes on ``[0+, T_a]``, ``[T_a, T_b]``, ``[T_b, T_R]`` of each branch,
                            ``T_a, T_b = STIFFNESS_BREAKPOINTS T_R`` (0.25, 0.75)
transmission error          one output revolution at the constant driving torque
                            ``T_TE = transmission_error_torque_band T_R``: forward
                            ``theta(-T_TE, x)`` (the load resists forward motion), reverse
                            ``theta(+T_TE, x)``; the figure is each curve's peak-to-peak
hysteresis loss             zero by assumption: the model has no friction, so the loop's two
                            branches coincide (reported as 0 with that reason, not computed)
rated torque from pressure  the smallest ``|T|`` at which the peak Hertz pressure at any
                            position reaches ``allowable_contact_pressure_MPa``
==========================  ==================================================================

The figures that depend on the position are given as minimum, mean and
maximum over the positions evaluated: one mesh period when all rollers and
slots are alike, one tooth pitch of output when they differ (the result
repeats after it, so this is the full output revolution's range), one full
output revolution once the ring has its own profile deviation
(:func:`~corr_cad.mechanics.row.windup.result_period_rad`). For lost motion,
backlash and transmission error the catalogue figure is the maximum; for a
rigidity it is the minimum (the guaranteed value).

Why here, in :mod:`corr_cad.mechanics`: the figures are properties of one
drive, computed from the windup; the checks and the Monte Carlo
(:mod:`corr_cad.tolerance`) consume them, so they sit below it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from corr_cad.errors import SolverError
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.row.windup import (
    ARCMIN_PER_RAD,
    ARCSEC_PER_RAD,
    NMM_PER_NM,
    Windup,
    mesh_period_rad,
    result_period_rad,
    revolution_classes,
    series_rigidity_Nmm_per_rad,
)

__all__ = [
    "TORQUE_LEVELS",
    "STIFFNESS_BREAKPOINTS",
    "HYSTERESIS_NOTE",
    "DatasheetSpec",
    "Datasheet",
    "datasheet",
    "rated_torque_from_pressure",
    "play_figures",
]

#: Torque levels of the windup curve from -T_R to +T_R (step 5 % of T_R).
TORQUE_LEVELS = 41
#: K1/K2/K3 breakpoints T_a, T_b as shares of T_R (strain-wave catalogues give
#: T1, T2 per size; these shares sit in their range and on the 5 % grid).
STIFFNESS_BREAKPOINTS = (0.25, 0.75)
#: Why the hysteresis loss is zero.
HYSTERESIS_NOTE = (
    "zero by assumption: the model has no friction (the paper's assumption 3), "
    "so the loading and unloading branches coincide; a real reducer's loss is mostly friction"
)


#: Smallest share of T_R a figure is read at (a band, the width of the rigidity
#: range): the curve's torque levels are shares rounded to 12 digits, and the
#: windup between two levels must stand well above float round-off, or a
#: secant divides by zero and the datasheet would hold inf.
MIN_SHARE = 1e-3
#: Smallest rated torque, N*mm (1e-3 N*m): below it the torques of the figures
#: (MIN_SHARE of T_R) near the subnormal floats.
MIN_RATED_TORQUE_NMM = 1.0


@dataclass(frozen=True)
class DatasheetSpec:
    """What the datasheet is evaluated at (the ``[datasheet]`` section).

    Attributes
    ----------
    rated_torque : float, N*mm
        T_R, the output torque the figures refer to.
    lost_motion_band : float
        ``b``: lost motion at ``+-b T_R`` (RV catalogues 0.03, strain-wave 0.04).
    rigidity_range : (float, float)
        ``T_1 / T_R, T_2 / T_R`` of the torsional rigidity.
    transmission_error_torque_band : float
        Driving torque of the transmission error, share of T_R.
    positions_per_mesh : int
        Positions per mesh period for the windup curve.
    transmission_error_positions_per_turn : int
        Positions per crank (input) turn of the transmission error.
    allowable_contact_pressure : float or None, MPa
        Rate the torque from contact pressure.
    series_rigidity_Nm_per_arcmin : float or None
        Rigidity in series with the contacts (bearings, crank, frame, housing).
    torque_levels : int
        Levels of the windup curve from -T_R to +T_R (odd, so that 0 is one).
    """

    rated_torque: float
    lost_motion_band: float = 0.03
    rigidity_range: tuple[float, float] = (0.5, 1.0)
    transmission_error_torque_band: float = 0.03
    positions_per_mesh: int = 16
    transmission_error_positions_per_turn: int = 360
    allowable_contact_pressure: float | None = None
    series_rigidity_Nm_per_arcmin: float | None = None
    torque_levels: int = TORQUE_LEVELS

    def __post_init__(self):
        def bad(name, value, allowed, works):
            raise SolverError(f"{name} = {value!r}: allowed range is {allowed}, e.g. {works}")

        T = self.rated_torque
        if not (isinstance(T, (int, float)) and math.isfinite(T) and T >= MIN_RATED_TORQUE_NMM):
            bad("rated_torque", T, f"[{MIN_RATED_TORQUE_NMM:g}, inf) N*mm", 2.86e6)
        for name in ("lost_motion_band", "transmission_error_torque_band"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and MIN_SHARE <= v < 1):
                bad(name, v, f"[{MIN_SHARE:g}, 1)", 0.03)
        lo, hi = self.rigidity_range
        if not (0 <= lo < hi <= 1 and hi - lo >= MIN_SHARE):
            rule = f"0 <= T_1 < T_2 <= 1, T_2 - T_1 >= {MIN_SHARE:g}"
            bad("rigidity_range", list(self.rigidity_range), rule, [0.5, 1.0])
        for name in ("positions_per_mesh", "transmission_error_positions_per_turn"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                bad(name, v, "integers >= 1", 16 if name == "positions_per_mesh" else 360)
        n = self.torque_levels
        if isinstance(n, bool) or not isinstance(n, int) or n < 3 or n % 2 == 0:
            bad("torque_levels", n, "odd integers >= 3", TORQUE_LEVELS)
        for name in ("allowable_contact_pressure", "series_rigidity_Nm_per_arcmin"):
            v = getattr(self, name)
            if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                bad(name, v, "(0, inf)", 1500.0 if "pressure" in name else 1000.0)

    def torques(self) -> np.ndarray:
        """The windup curve's torque levels, N*mm, ascending, zero as ``-0.0`` and ``+0.0``.

        The grid ``-T_R .. +T_R`` in ``torque_levels`` steps, with the lost
        motion band ``+-b T_R``, the rigidity range and the K breakpoints
        added where they are not on it.
        """
        T = self.rated_torque
        grid = np.linspace(-1.0, 1.0, self.torque_levels)
        extra = [self.lost_motion_band, *self.rigidity_range, *STIFFNESS_BREAKPOINTS, 1.0]
        shares = np.unique(np.round(np.concatenate([grid, extra, -np.asarray(extra)]), 12))
        shares = shares[shares != 0.0]
        neg, pos = shares[shares < 0] * T, shares[shares > 0] * T
        return np.concatenate([neg, [-0.0, 0.0], pos])


def _stats(values: np.ndarray) -> dict:
    v = np.asarray(values, dtype=float).reshape(-1)
    return {"min": float(v.min()), "mean": float(v.mean()), "max": float(v.max())}


@dataclass
class Datasheet:
    """The windup curve, the transmission error and the figures read off them.

    Arrays: ``torques`` (L,) N*mm; ``output_angles`` (P,) rad; ``windup`` and
    ``contact_windup`` (L, P) rad (with and without the series compliance);
    ``te_output_angles`` (N,) rad over one output revolution;
    ``te_forward``, ``te_reverse`` (N,) rad.
    """

    spec: DatasheetSpec
    span: str
    torques: np.ndarray
    output_angles: np.ndarray
    windup: np.ndarray
    contact_windup: np.ndarray
    te_output_angles: np.ndarray
    te_forward: np.ndarray
    te_reverse: np.ndarray
    te_positions_solved: int
    rated_from_pressure: dict | None = None
    peak_pressure_at_rated: np.ndarray | None = field(default=None, repr=False)
    #: ``model = "drive"``: row A's share of the moment, (L, P) at each torque level.
    row_a_share: np.ndarray | None = field(default=None, repr=False)
    #: With the crankshaft (:mod:`~corr_cad.mechanics.compliance_budget`): the windup's split.
    compliance_budget: dict | None = None

    def _level(self, share: float) -> int:
        """Index of the torque level at ``share`` of T_R."""
        T = share * self.spec.rated_torque
        # The levels are shares rounded to 12 digits (spec.torques): match to 1e-9 of T_R.
        near = np.abs(self.torques - T) <= 1e-9 * self.spec.rated_torque
        hit = np.flatnonzero(near & (np.signbit(self.torques) == (math.copysign(1.0, T) < 0)))
        if hit.size == 0:
            raise KeyError(f"torque {T:g} N*mm is not a level of the curve")
        return int(hit[0])

    def at(self, share: float, contact_only: bool = False) -> np.ndarray:
        """Windup (P,) rad at ``share`` of T_R (``-0.0``, ``+0.0`` for the ends at zero)."""
        w = self.contact_windup if contact_only else self.windup
        return w[self._level(share)]

    def _rigidity(self, a: float, b: float, contact_only: bool) -> np.ndarray:
        """Secant slopes on [a, b] T_R of both branches, N*m/arcmin, (2, P)."""
        out = []
        for s in (1.0, -1.0):
            ta, tb = s * a, s * b
            dT = (tb - ta) * self.spec.rated_torque / NMM_PER_NM
            dth = (self.at(tb, contact_only) - self.at(ta, contact_only)) * ARCMIN_PER_RAD
            out.append(dT / dth)
        return np.stack(out)

    def backlash(self) -> np.ndarray:
        """(P,) rad."""
        return self.at(0.0) - self.at(-0.0)

    def lost_motion(self) -> np.ndarray:
        """(P,) rad."""
        b = self.spec.lost_motion_band
        return self.at(b) - self.at(-b)

    def rigidity(self, contact_only: bool = False) -> np.ndarray:
        """Torsional rigidity of both branches, N*m/arcmin, (2, P): rows +T, -T."""
        return self._rigidity(*self.spec.rigidity_range, contact_only)

    def stiffness_K(self) -> dict[str, np.ndarray]:
        """K1, K2, K3 of both branches, N*m/arcmin, (2, P) each."""
        ta, tb = STIFFNESS_BREAKPOINTS
        return {
            "K1": self._rigidity(0.0, ta, False),
            "K2": self._rigidity(ta, tb, False),
            "K3": self._rigidity(tb, 1.0, False),
        }

    def transmission_error_peak_to_peak(self) -> dict[str, float]:
        """Peak-to-peak of each direction over one output revolution, arcsec."""
        return {
            "forward": float(np.ptp(self.te_forward) * ARCSEC_PER_RAD),
            "reverse": float(np.ptp(self.te_reverse) * ARCSEC_PER_RAD),
        }

    def check_values(self) -> dict[str, float]:
        """The catalogue figures ``[checks]`` judge (metric names of ``CHECK_METRICS``)."""
        te = self.transmission_error_peak_to_peak()
        return {
            "lost_motion_arcmin": float(self.lost_motion().max() * ARCMIN_PER_RAD),
            "torsional_rigidity_Nm_per_arcmin": float(self.rigidity().min()),
            "transmission_error_arcsec": max(te.values()),
        }

    def figures(self) -> dict:
        """Every figure as JSON-ready values in catalogue units (N*m, arcmin, arcsec)."""
        sp = self.spec
        T_R = sp.rated_torque / NMM_PER_NM
        series = sp.series_rigidity_Nm_per_arcmin
        b = sp.lost_motion_band
        te = self.transmission_error_peak_to_peak()
        k = self.stiffness_K()
        ta, tb = STIFFNESS_BREAKPOINTS
        rig = {
            "contact_only": _stats(self.rigidity(contact_only=True)),
            "with_series": _stats(self.rigidity()) if series is not None else None,
            "series_rigidity_Nm_per_arcmin": series,
            "from_torque_Nm": sp.rigidity_range[0] * T_R,
            "to_torque_Nm": sp.rigidity_range[1] * T_R,
            "headline": float(self.rigidity().min()),
            "headline_basis": (
                "the contacts in series with series_rigidity_Nm_per_arcmin"
                if series is not None
                else "the contacts only (no series rigidity given): bearings, shafts and "
                "housing are not in it"
            ),
            # the same value under its old name (deprecated: it is a catalogue figure only
            # with a series rigidity)
            "catalogue": float(self.rigidity().min()),
            "definition": "(T_2 - T_1) / (theta(T_2) - theta(T_1)) on both branches",
        }
        out = {
            "rated_torque_Nm": T_R,
            "positions": {
                "count": int(len(self.output_angles)),
                "span": self.span,
                "output_angle_from_deg": float(np.degrees(self.output_angles[0])),
                "output_angle_to_deg": float(np.degrees(self.output_angles[-1])),
                "positions_per_mesh": sp.positions_per_mesh,
            },
            "torque_levels": int(len(self.torques)),
            "backlash_arcmin": {
                **_stats(self.backlash() * ARCMIN_PER_RAD),
                "definition": "theta(0+) - theta(0-)",
            },
            "lost_motion_arcmin": {
                **_stats(self.lost_motion() * ARCMIN_PER_RAD),
                "band": b,
                "torque_Nm": b * T_R,
                "definition": "theta(+b T_R) - theta(-b T_R)",
            },
            "torsional_rigidity_Nm_per_arcmin": rig,
            "stiffness_Nm_per_arcmin": {
                "breakpoints_Nm": [ta * T_R, tb * T_R, T_R],
                "K1": _stats(k["K1"]),
                "K2": _stats(k["K2"]),
                "K3": _stats(k["K3"]),
                "definition": "slopes on [0+, T_a], [T_a, T_b], [T_b, T_R] of both branches",
            },
            "transmission_error_arcsec": {
                "forward_peak_to_peak": te["forward"],
                "reverse_peak_to_peak": te["reverse"],
                "catalogue": max(te.values()),
                "driving_torque_Nm": sp.transmission_error_torque_band * T_R,
                "positions": int(len(self.te_output_angles)),
                "positions_solved": int(self.te_positions_solved),
                "definition": "peak-to-peak of theta(-+T_TE, x) over one output revolution",
            },
            "hysteresis_loss_arcmin": 0.0,
            "hysteresis_loss_note": HYSTERESIS_NOTE,
        }
        if self.row_a_share is not None:
            at_rated = np.stack([self._level(1.0), self._level(-1.0)])
            out["row_a_share"] = {
                **_stats(self.row_a_share[at_rated]),
                "definition": "share of the crank moment carried by row A at +-T_R, over the "
                "positions and both directions together (row B carries the rest; "
                "row_a_share_by_direction gives each direction)",
            }
            out["row_a_share_by_direction"] = {
                "positive": _stats(self.row_a_share[at_rated[0]]),
                "negative": _stats(self.row_a_share[at_rated[1]]),
                "definition": "share of the crank moment carried by row A at +T_R (positive) "
                "and at -T_R (negative), over the positions (row B carries the rest)",
            }
        if self.peak_pressure_at_rated is not None:
            out["peak_contact_pressure_at_rated_MPa"] = float(self.peak_pressure_at_rated.max())
        if self.rated_from_pressure is not None:
            out["rated_torque_from_contact_pressure"] = self.rated_from_pressure
        if self.compliance_budget is not None:
            out["compliance_budget"] = self.compliance_budget
        return out


def rated_torque_from_pressure(windup: Windup, allowable: float, start: float) -> dict:
    """Smallest ``|T|`` (N*mm) at which the peak Hertz pressure reaches ``allowable`` (MPa).

    Both directions, over the windup's positions; bisection on ``log T``
    (the peak pressure grows with the torque) to a relative 1e-6. ``start``
    is the first torque tried (T_R); it is doubled until the pressure is
    reached. A preload that reaches the allowable at no torque gives 0.
    """
    from scipy.optimize import brentq

    def excess(T: float) -> float:
        return float(windup.peak_pressure(T).max()) - allowable

    found = {}
    for name, s in (("positive", 1.0), ("negative", -1.0)):
        tiny = s * start * 1e-9
        if excess(tiny) >= 0:
            found[name] = 0.0
            continue
        hi = start
        while excess(s * hi) < 0:
            hi *= 2.0
            if hi > start * 2.0**40:
                raise SolverError("rated torque from pressure: the allowable is never reached")
        lo = hi / 2.0
        while lo > abs(tiny) and excess(s * lo) >= 0:
            lo /= 2.0
        x = brentq(lambda u, s=s: excess(s * math.exp(u)), math.log(lo), math.log(hi), rtol=1e-6)
        found[name] = math.exp(x)
    T = min(found.values())
    return {
        "allowable_MPa": float(allowable),
        "torque_Nm": T / NMM_PER_NM,
        "positive_Nm": found["positive"] / NMM_PER_NM,
        "negative_Nm": found["negative"] / NMM_PER_NM,
        "definition": "smallest |T| at which the peak Hertz pressure at any position "
        "reaches the allowable",
    }


def datasheet(
    design: GearDesign,
    spec: DatasheetSpec,
    *,
    errors: ManufacturingErrors | None = None,
    load_share: float = 0.55,
    contact_model: str = "nonlinear",
    variants: tuple[str, ...] = (),
    psi_contact_limit: float = math.pi,
    drive: dict | None = None,
) -> Datasheet:
    """The windup curve at every position, the transmission error and the figures.

    >>> from corr_cad import GearDesign
    >>> from corr_cad.mechanics.datasheet import DatasheetSpec, datasheet
    >>> ds = datasheet(GearDesign(), DatasheetSpec(rated_torque=2.86e6))
    >>> f = ds.figures()
    >>> f["backlash_arcmin"]["max"], f["positions"]["span"]
    (0.0, 'one mesh period')
    >>> round(f["torsional_rigidity_Nm_per_arcmin"]["contact_only"]["min"], -2)
    23600.0

    ``drive``: the two-row drive model (``[solver] model = "drive"``) with
    the keyword arguments of :class:`~corr_cad.mechanics.drive.drive_windup.DriveWindup`
    (``errors_b``, ``bearing``, ``bearing_b``); ``load_share`` is then unused
    and the datasheet records row A's share at each torque level.
    """
    errors = errors or ManufacturingErrors()
    common = {
        "errors": errors,
        "load_share": load_share,
        "contact_model": contact_model,
        "variants": variants,
        "psi_contact_limit": psi_contact_limit,
        "series_rigidity_Nm_per_arcmin": spec.series_rigidity_Nm_per_arcmin,
    }
    make = _windup_factory(common, drive)
    periodic = span_errors(design, errors, drive, variants)
    period = result_period_rad(design, periodic, variants)
    mesh = mesh_period_rad(design)
    n = int(round(period / mesh)) * spec.positions_per_mesh
    span = {1: "one mesh period", design.roller_count: "one tooth pitch (repeats z times)"}.get(
        int(round(period / mesh)), "one output revolution"
    )
    x = period * np.arange(n) / n
    w = make(design, x)
    torques = spec.torques()
    contact = np.stack([w.contact_theta(T) for T in torques])
    share = np.stack([w.row_a_share(T) for T in torques]) if drive is not None else None
    k_series = series_rigidity_Nmm_per_rad(spec.series_rigidity_Nm_per_arcmin)
    total = contact + torques[:, None] / k_series
    te_x, index = revolution_classes(
        design, spec.transmission_error_positions_per_turn, periodic, variants
    )
    wt = make(design, te_x)
    T_te = spec.transmission_error_torque_band * spec.rated_torque
    N = len(index)
    out = Datasheet(
        spec=spec,
        span=span,
        torques=torques,
        output_angles=x,
        windup=total,
        contact_windup=contact,
        te_output_angles=2.0 * np.pi * np.arange(N) / N,
        te_forward=wt.theta(-T_te)[index],
        te_reverse=wt.theta(T_te)[index],
        te_positions_solved=len(te_x),
        peak_pressure_at_rated=np.maximum(
            w.peak_pressure(spec.rated_torque), w.peak_pressure(-spec.rated_torque)
        ),
        row_a_share=share,
    )
    if spec.allowable_contact_pressure is not None:
        out.rated_from_pressure = rated_torque_from_pressure(
            w, spec.allowable_contact_pressure, spec.rated_torque
        )
    if (drive or {}).get("crank") is not None:
        from corr_cad.mechanics.compliance_budget import compliance_budget

        out.compliance_budget = compliance_budget(
            w, spec.rated_torque, spec.rigidity_range, spec.series_rigidity_Nm_per_arcmin
        )
    return out


def span_errors(design, errors, drive: dict | None, variants: tuple[str, ...] = ()):
    """The errors whose periodicity the positions follow: under the drive, the row that
    repeats last (row B's own rollers or ring deviation need their span even when row A's
    parts are alike). The periods nest (a mesh period divides a tooth pitch divides a
    revolution), so the longer one is both rows' common period."""
    b = (drive or {}).get("errors_b")
    if b is None:
        return errors
    longer = result_period_rad(design, b, variants) > result_period_rad(design, errors, variants)
    return b if longer else errors


def _windup_factory(common: dict, drive: dict | None):
    """``make(design, output_angles)``: the one-row windup, or the drive's."""
    if drive is None:
        return lambda design, x: Windup(design, x, **common)
    from corr_cad.mechanics.drive.drive_windup import DriveWindup

    kw = {k: v for k, v in common.items() if k != "load_share"}
    return lambda design, x: DriveWindup(design, x, **kw, **drive)


def play_figures(
    design: GearDesign,
    spec: DatasheetSpec,
    *,
    errors: ManufacturingErrors | None = None,
    load_share: float = 0.55,
    contact_model: str = "nonlinear",
    variants: tuple[str, ...] = (),
    psi_contact_limit: float = math.pi,
    drive: dict | None = None,
) -> dict:
    """Backlash, lost motion and transmission error without the windup curve (catalogue units).

    The figures a ring's own errors change, as :func:`datasheet` defines
    them, at the transmission-error positions (``transmission_error_positions_per_turn``
    per crank turn over one output revolution, each periodic class solved
    once): free ends, ``theta(+-b T_R)`` and ``theta(-+T_TE)``. What the
    inspection report predicts for a measured ring; five windup solves
    instead of the datasheet's curve.
    """
    errors = errors or ManufacturingErrors()
    x, index = revolution_classes(
        design,
        spec.transmission_error_positions_per_turn,
        span_errors(design, errors, drive, variants),
        variants,
    )
    common = {
        "errors": errors,
        "load_share": load_share,
        "contact_model": contact_model,
        "variants": variants,
        "psi_contact_limit": psi_contact_limit,
        "series_rigidity_Nm_per_arcmin": spec.series_rigidity_Nm_per_arcmin,
    }
    w = _windup_factory(common, drive)(design, x)
    T_R = spec.rated_torque
    b, b_te = spec.lost_motion_band, spec.transmission_error_torque_band
    lo, hi = w.free_ends()
    lm = w.theta(b * T_R) - w.theta(-b * T_R)
    fwd = w.theta(-b_te * T_R)[index]
    rev = w.theta(b_te * T_R)[index]
    return {
        "positions": int(len(index)),
        "positions_solved": int(len(x)),
        "backlash_arcmin": {
            **_stats((hi - lo) * ARCMIN_PER_RAD),
            "definition": "theta(0+) - theta(0-)",
        },
        "lost_motion_arcmin": {
            **_stats(lm * ARCMIN_PER_RAD),
            "band": b,
            "torque_Nm": b * T_R / NMM_PER_NM,
            "definition": "theta(+b T_R) - theta(-b T_R)",
        },
        "transmission_error_arcsec": {
            "forward_peak_to_peak": float(np.ptp(fwd) * ARCSEC_PER_RAD),
            "reverse_peak_to_peak": float(np.ptp(rev) * ARCSEC_PER_RAD),
            "driving_torque_Nm": b_te * T_R / NMM_PER_NM,
            "definition": "peak-to-peak of theta(-+T_TE, x) over one output revolution",
        },
    }
