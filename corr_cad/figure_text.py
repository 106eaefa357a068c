"""Numbers as a catalogue prints them: one formatter for console, plots and report.

A figure is written positionally with thousands separators and a fixed
number of significant digits, never in scientific notation: ``21,256``, not
``2.126e+04``; ``0.01885``; ``0``. Every place that shows a datasheet or
Monte Carlo figure (the console summary, the checks, the plots' labels and
legends) takes it from here, so one figure reads the same everywhere.
"""

from __future__ import annotations

import math

__all__ = ["figure", "catalogue_number", "UNITS", "unit_of"]


def figure(v: float, digits: int = 4) -> str:
    """``v`` with ``digits`` significant digits (all of its integer digits), positional.

    Thousands separated by commas, trailing zeros after the point dropped,
    ``-0`` written ``0``; NaN and infinities as ``nan``, ``inf``, ``-inf``.

    >>> [figure(x) for x in (21256.3, 2.126e4, 0.018846, 1.735e-18, 0.0, -0.0, 7.0, 1e-7)]
    ['21,256', '21,260', '0.01885', '0.000000000000000001735', '0', '0', '7', '0.0000001']
    >>> figure(0.99996), figure(-1234.6, 3)
    ('1', '-1,235')
    """
    v = float(v)
    if not math.isfinite(v):
        return str(v)
    if v == 0.0:
        return "0"
    mag = math.floor(math.log10(abs(v)))
    text = f"{v:,.{max(0, digits - 1 - mag)}f}"
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return "0" if text in ("-0", "0") else text


#: The unit of each Monte Carlo metric (``montecarlo.csv`` columns and the
#: manifest's percentile table).
UNITS = {
    "peak_gear_force": "N",
    "peak_pressure": "MPa",
    "min_loaded_rollers": "rollers",
    "backlash_arcmin": "arcmin",
    "lost_motion_arcmin": "arcmin",
    "torsional_rigidity_Nm_per_arcmin": "N*m/arcmin",
    "transmission_error_arcsec": "arcsec",
    "binding_pressure_MPa": "MPa",
    "binds": "0/1",
}


def unit_of(metric: str) -> str:
    """The unit of a Monte Carlo metric, or of a key named ``..._<unit>``; "" if none."""
    if metric in UNITS:
        return UNITS[metric]
    for suffix, unit in (("_mm", "mm"), ("_MPa", "MPa"), ("_N", "N"), ("_arcmin", "arcmin")):
        if metric.endswith(suffix):
            return unit
    return ""


def catalogue_number(value: float, digits: int = 4) -> str:
    """``value`` with ``digits`` significant digits, thousands separated, never in e-notation.

    >>> catalogue_number(21256.3), catalogue_number(0.0123456), catalogue_number(2.2e-19)
    ('21,256', '0.01235', '0')
    >>> catalogue_number(2860.0), catalogue_number(-0.5)
    ('2,860', '-0.5')
    """
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"not a finite number: {v!r}")
    if abs(v) < 1e-9:
        return "0"
    decimals = max(0, digits - 1 - math.floor(math.log10(abs(v))))
    text = f"{v:,.{decimals}f}"
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return text
