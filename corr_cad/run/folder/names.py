"""Every file name a run may write into its output folder: one pattern list per format.

This is the one place that says which names are corr-cad's. The output
folder code (:mod:`corr_cad.run.folder.outputs`) replaces or removes a file only if
its name matches one of these patterns (besides ``manifest.json`` and its
own staging and lock names), whatever a ``manifest.json`` claims; the commit
refuses a staged file whose name the scene's formats do not declare, so a
stage that writes a new name must add it here first.

>>> is_output_name("roller.dxf"), is_output_name("notes.txt")
(True, False)
>>> is_output_name("assembly_007p5deg.stl", ["stl"]), is_output_name("roller.stl", ["dxf"])
(True, False)
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from corr_cad.tolerance.sweeps import PAPER_SWEEPS

__all__ = [
    "OUTPUT_PATTERNS",
    "PART_FILE_STEMS",
    "GEAR_FILE_STEMS",
    "FIRST_STAGE_FILE_STEMS",
    "BEARING_FILE_STEMS",
    "ANGLE_TAG_PATTERN",
    "is_output_name",
]

#: The four parts, as every DXF, mesh and STEP file names them.
PART_FILE_STEMS = ("inner_gear", "disk_cam", "roller", "teeth_frame")
#: The first gear stage's gears (``[first_stage]``), as their DXF files name them.
GEAR_FILE_STEMS = ("pinion", "wheel", "crank_gear")
#: Every part of the first gear stage, as its mesh and STEP files name them.
FIRST_STAGE_FILE_STEMS = (*GEAR_FILE_STEMS, "crankshaft", "wheel_bearing", "crank_bearing")
#: The cams' needle bearings (``model = "drive"`` with ``[bearings.eccentric]``): the
#: needles (row B's own where they differ) and the crankshaft with its eccentrics.
BEARING_FILE_STEMS = ("needle", "needle_b", "crankshaft")
#: What :func:`corr_cad.export.files.angle_tag` makes of an angle in [-3600, 3600] deg.
ANGLE_TAG_PATTERN = r"m?[0-9]{3,4}(?:p[0-9]{1,3})?deg"


def _any(names: Iterable[str]) -> str:
    return "(?:" + "|".join(re.escape(n) for n in names) + ")"


_PARTS = _any(PART_FILE_STEMS)

#: ``[export] formats`` entry -> the names (regular expressions, matched in
#: full) of every file that format can write.
OUTPUT_PATTERNS: dict[str, tuple[str, ...]] = {
    "dxf": (
        rf"{_PARTS}\.dxf",
        r"measured_profile\.dxf",
        rf"{_any(FIRST_STAGE_FILE_STEMS)}\.dxf",
        rf"{_any(BEARING_FILE_STEMS)}\.dxf",
    ),
    "png": (r"preview\.png", r"modification\.png", r"first_stage\.png"),
    "forces": (r"forces\.(?:csv|png)", r"forces_summary\.json", r"load_distribution\.png"),
    **{
        fmt: (
            rf"{_PARTS}\.{fmt}",
            # FreeCAD's variant of each assembly (one compound) comes with `step`.
            rf"assembly_{ANGLE_TAG_PATTERN}{'(?:_freecad)?' if fmt == 'step' else ''}\.{fmt}",
            rf"{_any(FIRST_STAGE_FILE_STEMS)}\.{fmt}",
            rf"{_any(BEARING_FILE_STEMS)}\.{fmt}",
        )
        for fmt in ("stl", "3mf", "glb", "ply", "step")
    },
    "interference": (r"(?:interference|clearance)\.(?:csv|png)",),
    "montecarlo": (r"montecarlo\.(?:csv|png)", r"montecarlo_summary\.json"),
    "allocation": (r"allocation\.(?:csv|json)",),
    "sweeps": (
        rf"sweep_{_any(PAPER_SWEEPS)}\.(?:csv|png)",
        r"sweeps_vs_paper\.csv",
        r"sweeps\.json",
    ),
    "datasheet": (
        r"datasheet\.(?:json|html)",
        r"assembly\.(?:json|png)",
        r"(?:windup|transmission_error|hysteresis)\.csv",
        r"(?:hysteresis|transmission_error|compliance)\.png",
        r"efficiency\.(?:csv|png)",
        r"life\.csv",
        r"temperature\.(?:csv|png)",
    ),
    "edm": (r"inner_gear_edm\.(?:dxf|nc)",),
    "cmm": (r"inner_gear_nominal\.csv",),
    "inspection": (r"inspection\.(?:csv|json|png)",),
    "modification": (
        r"modification\.json",
        r"modification_tradeoff\.png",
        r"modified\.toml",
        r"modified_normal\.csv",
    ),
    "sizing": (r"sizing\.csv", r"pareto\.(?:csv|png)", r"design_\d\d\.toml"),
    "report": (r"report\.html",),
}

_COMPILED = {f: re.compile("|".join(p)) for f, p in OUTPUT_PATTERNS.items()}


def is_output_name(name: object, formats: Iterable[str] | None = None) -> bool:
    """Can a run with ``formats`` (default: any format) write a file called ``name``?"""
    if not isinstance(name, str):
        return False
    chosen = _COMPILED.values() if formats is None else [_COMPILED.get(f) for f in formats]
    # A format without patterns here writes nothing corr-cad may commit: its
    # files are refused as undeclared (tests/test_contract_holes checks FORMATS).
    return any(rx.fullmatch(name) for rx in chosen if rx is not None)
