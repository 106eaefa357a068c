"""Design checks: the limits a drive must meet, and the metrics they are judged on.

A check bounds one metric of a force solution from above (``max_*``) or
below (``min_*``). :func:`sample_metrics` reduces a (sample-major) force
result to those metrics; :func:`evaluate_checks` gives pass/fail and margin;
:func:`evaluate_failure_probability` gates a Monte Carlo. Pure numpy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from corr_cad.mechanics.row.solver import loaded_mask

__all__ = [
    "ARCMIN_PER_RAD",
    "Checks",
    "CHECK_METRICS",
    "DATASHEET_METRICS",
    "sample_metrics",
    "evaluate_checks",
    "evaluate_failure_probability",
    "replace_checks",
]

ARCMIN_PER_RAD = 180.0 * 60.0 / math.pi


@dataclass(frozen=True)
class Checks:
    """Limits a design must meet; ``None`` means not checked."""

    max_contact_pressure: float | None = None  # MPa
    max_gear_force: float | None = None  # N
    min_loaded_rollers: int | None = None
    #: Lost motion at +-``[datasheet] lost_motion_band`` of the rated torque
    #: (catalogue definition; before the datasheet this name meant the backlash).
    max_lost_motion_arcmin: float | None = None
    #: Free rotation at zero torque, every clearance open.
    max_backlash_arcmin: float | None = None
    min_torsional_rigidity_Nm_per_arcmin: float | None = None
    max_transmission_error_arcsec: float | None = None
    #: Forward efficiency (minimum over the ``[friction]`` map) and system L10
    #: at the rated torque: judged on the nominal design only.
    min_efficiency: float | None = None
    min_life_h: float | None = None
    #: First-stage limits (``[first_stage]``), judged on the nominal gears only.
    max_first_stage_bending_MPa: float | None = None
    max_first_stage_contact_MPa: float | None = None
    #: Largest allowed Monte Carlo failure probability per limit; ``None``:
    #: the Monte Carlo is reported but only the nominal design is gated.
    max_failure_probability: float | None = None
    #: Largest allowed probability that a Monte Carlo sample binds at zero
    #: torque (:mod:`corr_cad.mechanics.binding`); gates the Monte Carlo only.
    max_binding_probability: float | None = None

    def active(self) -> dict[str, float]:
        """The limits that are set (not the failure-probability gate)."""
        return {k: v for k, v in self.__dict__.items() if v is not None and k in CHECK_METRICS}

    def datasheet_active(self) -> dict[str, float]:
        """The limits on datasheet figures (they need the windup; see :data:`DATASHEET_METRICS`)."""
        return {k: v for k, v in self.active().items() if CHECK_METRICS[k][0] in DATASHEET_METRICS}

    def montecarlo_active(self) -> dict[str, float]:
        """The limits the Monte Carlo and allocation judge: every limit.

        The datasheet's need the Monte Carlo's datasheet pass
        (:mod:`corr_cad.tolerance.mc_datasheet`); efficiency and life are
        judged on the nominal design only (:data:`NOMINAL_ONLY_METRICS`).
        """
        return {
            k: v
            for k, v in self.active().items()
            if CHECK_METRICS[k][0] not in NOMINAL_ONLY_METRICS
        }


#: check -> (metric, sense): "max" limits bound the metric from above.
CHECK_METRICS = {
    "max_contact_pressure": ("peak_pressure", "max"),
    "max_gear_force": ("peak_gear_force", "max"),
    "min_loaded_rollers": ("min_loaded_rollers", "min"),
    "max_lost_motion_arcmin": ("lost_motion_arcmin", "max"),
    "max_backlash_arcmin": ("backlash_arcmin", "max"),
    "min_torsional_rigidity_Nm_per_arcmin": ("torsional_rigidity_Nm_per_arcmin", "min"),
    "max_transmission_error_arcsec": ("transmission_error_arcsec", "max"),
    "min_efficiency": ("efficiency", "min"),
    "min_life_h": ("life_h", "min"),
}
#: Metrics of the friction and life models: the datasheet computes them for the
#: nominal design; the Monte Carlo does not.
NOMINAL_ONLY_METRICS = ("efficiency", "life_h")

#: Metrics read off the windup (:meth:`corr_cad.mechanics.datasheet.Datasheet.check_values`):
#: the Monte Carlo computes them in its datasheet pass (:mod:`corr_cad.tolerance.mc_datasheet`).
DATASHEET_METRICS = (
    "lost_motion_arcmin",
    "torsional_rigidity_Nm_per_arcmin",
    "transmission_error_arcsec",
    *NOMINAL_ONLY_METRICS,
)


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
        "backlash_arcmin": per(res.backlash).max(axis=1) * ARCMIN_PER_RAD,
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


def replace_checks(checks: Checks, keep: str) -> Checks:
    """Only the check ``keep`` active."""
    return Checks(**{k: (v if k == keep else None) for k, v in checks.__dict__.items()})
