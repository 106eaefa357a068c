"""Figures of ``datasheet.json`` made from the Monte Carlo's.

* ``as_built``: the Monte Carlo's percentiles of the catalogue figures (with
  ``[tolerances]`` and the ``montecarlo`` format), which the page gives beside the nominal.
"""

from __future__ import annotations

__all__ = ["AS_BUILT_METRICS", "as_built"]


#: The Monte Carlo's metrics the page gives as built (``datasheet.json`` ``as_built``).
AS_BUILT_METRICS = (
    "lost_motion_arcmin",
    "transmission_error_arcsec",
    "torsional_rigidity_Nm_per_arcmin",
)


def as_built(mc: dict | None) -> dict:
    """``{"as_built": ...}``: the Monte Carlo's percentiles of the datasheet metrics
    (``montecarlo_summary.json`` ``percentiles``), or ``{}`` when it has none."""
    pct = (mc or {}).get("percentiles") or {}
    got = {m: pct[m] for m in AS_BUILT_METRICS if m in pct}
    if not got:
        return {}
    return {
        "as_built": {
            "samples": mc["samples"],
            **got,
            "definition": "percentiles over the Monte Carlo's samples of [tolerances] "
            "(montecarlo_summary.json): each sample's catalogue figure, at the Monte Carlo's "
            "positions ([montecarlo] datasheet_positions_per_mesh)",
        }
    }
