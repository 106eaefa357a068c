"""Figures as a catalogue prints them, in the console, the checks and the assembly line.

No scientific notation (21,256 N*m/arcmin, not 2.126e+04), one value of a
figure in the datasheet table and in its check, a binding interval that
starts at exactly 0, units in the Monte Carlo percentile table, the chosen
roller class named and a modified ring called modified.
"""

import re

import numpy as np

from corr_cad.figure_text import figure
from corr_cad.run.console import assembly_line, summary_lines
from corr_cad.run.scene.scene import parse_scene
from corr_cad.run.stages.stages_datasheet import ring_label
from corr_cad.tolerance.mc_datasheet import binding_probability

SCI = re.compile(r"\d[eE][+-]?\d")


def _stats(lo, mean, hi):
    return {"min": lo, "mean": mean, "max": hi}


def _manifest():
    rig = 21256.3
    return {
        "files": {},
        "datasheet": {
            "rated_torque_Nm": 2860.0,
            "positions": {"count": 4, "span": "one mesh period"},
            "backlash_arcmin": _stats(0.91, 0.913, 0.914),
            "lost_motion_arcmin": {**_stats(0.942, 0.9424, 0.9429), "band": 0.03},
            "torsional_rigidity_Nm_per_arcmin": {
                "with_series": None,
                "contact_only": _stats(rig, 21300.0, 21400.0),
                "from_torque_Nm": 1430.0,
                "to_torque_Nm": 2860.0,
            },
            "stiffness_Nm_per_arcmin": {
                "K1": {"min": 11014.2},
                "K2": {"min": 17576.0},
                "K3": {"min": 19687.0},
                "breakpoints_Nm": [715.0, 2145.0, 2860.0],
            },
            "transmission_error_arcsec": {
                "forward_peak_to_peak": 0.04832,
                "reverse_peak_to_peak": 1.2e-5,
            },
        },
        "montecarlo": {
            "samples": 200,
            "percentiles": {
                "peak_gear_force": {"p50": 6617.2},
                "torsional_rigidity_Nm_per_arcmin": {"p5": 13069.0},
                "min_loaded_rollers": {"p5": 5.0},
            },
            "failure_probability": {"min_torsional_rigidity_Nm_per_arcmin": 0.0},
            "binding_probability": binding_probability(np.zeros(200)),
        },
        "checks": {
            "min_torsional_rigidity_Nm_per_arcmin": {
                "passed": True,
                "value": rig,
                "limit": 10000.0,
            }
        },
        "assembly": {
            "ring": "modified ring, equidistant +0.01 mm",
            "chosen_class_um": -2.0,
            "chosen_backlash_arcmin": 0.81234,
            "target_backlash_arcmin": 1.0,
        },
    }


def test_no_scientific_notation_and_one_value_per_figure():
    lines = summary_lines(_manifest(), "out")
    text = "\n".join(lines)
    assert not SCI.search(text), [ln for ln in lines if SCI.search(ln)]
    table = next(ln for ln in lines if ln.startswith("  rigidity, contacts"))
    check = next(ln for ln in lines if ln.startswith("check min_torsional"))
    assert table.split()[2] == "21,256" and "value 21,256," in check
    assert "reverse 0.000012 arcsec" in text


def test_binding_interval_starts_at_zero_and_percentiles_carry_units():
    lo, hi = binding_probability(np.zeros(200))["wilson_interval"]
    assert lo == 0.0 and 0.0 < hi < 0.02
    assert binding_probability(np.ones(50))["wilson_interval"][1] == 1.0
    lines = summary_lines(_manifest(), "out")
    assert "  peak_gear_force (N): p50 6,617" in lines
    assert "  torsional_rigidity_Nm_per_arcmin (N*m/arcmin): p5 13,069" in lines
    assert "  min_loaded_rollers (rollers): p5 5" in lines
    assert any(ln.endswith("Wilson interval 0 to 0.01885)") for ln in lines), lines


def test_console_names_the_chosen_class_and_a_modified_ring():
    lines = summary_lines(_manifest(), "out")
    line = next(ln for ln in lines if ln.startswith("selective assembly"))
    assert line == (
        "selective assembly (modified ring, equidistant +0.01 mm): fit roller class -2 um, "
        "backlash 0.8123 arcmin (target 1)"
    )
    none = assembly_line({"ring": "nominal ring", "chosen_class_um": None, "reason": "r"})
    assert "NO CLASS FITS: r" in none
    mod = parse_scene({"modification": {"equidistant_mm": 0.01, "shift_mm": -0.002}})
    assert ring_label(mod) == "modified ring, equidistant +0.01 mm, shift -0.002 mm"
    assert ring_label(parse_scene({"export": {"formats": ["dxf"]}})) == "nominal ring"


def test_figure_written_out():
    """Positional, all integer digits, four significant digits otherwise (by hand)."""
    assert figure(21256.3) == "21,256" and figure(2.126e4) == "21,260"
    assert figure(0.018846) == "0.01885" and figure(-0.0) == "0" and figure(1e-7) == "0.0000001"
    assert figure(1234567.8, 5) == "1,234,568" and figure(0.5) == "0.5"
