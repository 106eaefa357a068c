"""Pipeline pieces of the profile modification (issue 20): the manifest record and
``modification.png``. The modified profile itself reaches every stage through
:func:`corr_cad.run.stages.context.modified_curve` and
:func:`corr_cad.run.stages.context.scene_errors`.
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.run.stages.context import RunContext

__all__ = [
    "modification_manifest",
    "modification_png",
    "modification_design",
    "modified_toml",
    "range_edges",
    "SHOP_FORMATS",
    "PLOT_POINTS",
]

#: Roll angles of the plot and the manifest's summary, over one tooth space.
PLOT_POINTS = 721


def _curves(ctx: RunContext) -> tuple[np.ndarray, dict]:
    from corr_cad.geometry.modification import family_clearances

    psi = np.linspace(-math.pi, math.pi, PLOT_POINTS)
    return psi, family_clearances(ctx.scene.design, ctx.scene.modification, psi)


def modification_manifest(ctx: RunContext) -> dict:
    """What ``manifest.json`` records of ``[modification]``."""
    psi, curves = _curves(ctx)
    tot = curves["total"]
    at = {f"{a:g}": float(np.interp(math.radians(a), psi, tot)) for a in (0.0, 45.0, 90.0, 135.0)}
    return {
        **ctx.scene.modification.as_dict(),
        "families": list(ctx.scene.modification.families()),
        "flank_clearance_mm": {
            "definition": "exact distance from the nominal roller centre to the modified working "
            "profile, less r, along the tooth space (psi 0 tooth space, 180 tooth tip)",
            "min": float(tot.min()),
            "max": float(tot.max()),
            "at_psi_deg": at,
        },
        "outputs": "every output follows the modified profile; the conjugate profile is on "
        "layer CONJUGATE_PROFILE of inner_gear.dxf",
    }


def modification_png(ctx: RunContext) -> None:
    from corr_cad.export.modification_plots import modification_png as plot

    psi, curves = _curves(ctx)
    p = plot(np.degrees(psi), curves, ctx.out / "modification.png", ctx.scene.design)
    ctx.files.append(p.name)


#: ``modified.toml``'s formats: the shop files of the designed ring.
SHOP_FORMATS = ("dxf", "edm", "cmm", "step")

#: Sections ``modified.toml`` may carry over from the design scene (non-default
#: keys only); the studies, checks and forces that designed it are left behind.
_CARRIED = ("design", "export", "errors", "edm", "inspection", "budget")


def _shop_formats() -> list[str]:
    """:data:`SHOP_FORMATS`, without ``step`` where Open CASCADE is not installed."""
    import importlib.util

    ocp = importlib.util.find_spec("OCP") is not None
    return [f for f in SHOP_FORMATS if f != "step" or ocp]


def _without_no_effect(data: dict, formats: tuple[str, ...]) -> dict:
    """``data`` less every section and key the loader would call without effect."""
    from corr_cad.run.scene.scene_text import no_effect_warnings

    while True:
        found = False
        for line in no_effect_warnings(data, formats, False):
            what = line.split(" has no effect", 1)[0]  # "[section]" or "[section] key"
            section, _, key = what.partition("] ")
            section = section.lstrip("[").rstrip("]")
            if key and key in data.get(section, {}):
                del data[section][key]
                found = True
            elif not key and section in data:
                del data[section]
                found = True
            if section in data and not data[section]:
                del data[section]
        if not found:
            return data


#: The drive's part of ``modified.toml`` under ``model = "drive"``: the model and its
#: law (``[solver]``), row B's errors and the cam bearings, as TOML tables.
_DRIVE_CARRIED = (
    ("solver", ("solver",)),
    ("errors.row_b", ("errors", "row_b")),
    ("bearings.eccentric", ("bearings", "eccentric")),
    ("bearings.eccentric_b", ("bearings", "eccentric_b")),
    ("crankshaft", ("crankshaft",)),
    ("bearings.crank", ("bearings", "crank")),
)
#: Sections whose presence alone means something (the crankshaft is in the drive with
#: either, whatever its keys): written where the scene gives them, even with no key.
_CARRIED_EMPTY = ("crankshaft", "bearings.crank")


def _carry_drive(scene, data: dict) -> None:
    """Under ``model = "drive"``: ``[solver] model`` and ``contact_law`` and the drive's
    sections (their keys that differ from the defaults) into ``data``. The ring is the
    same part under either model, but ``[design] slot_clearance`` and the drive's
    sections load only with the model, and a study added to the scene needs them."""
    from corr_cad.run.scene.scene_schema import SCHEMA

    if not scene.solver.drive:
        return
    for section, path in _DRIVE_CARRIED:
        vals = scene.source.get(section, {})
        keys = SCHEMA[section]
        if section == "solver":
            vals = {k: v for k, v in vals.items() if k in ("model", "contact_law")}
        kept = {k: v for k, v in vals.items() if k in keys and v != keys[k].default}
        given = section in _CARRIED_EMPTY and section in scene.source
        if section == "solver" or kept or given:  # an override without keys is none
            where = data
            for part in path[:-1]:
                where = where.setdefault(part, {})
            where[path[-1]] = kept


def modified_toml(
    scene,
    equidistant_mm: float,
    shift_mm: float,
    normal_table: str | None = None,
    folder=None,
) -> str:
    """The scene that writes the shop files of the chosen modification (``modified.toml``).

    Formats :data:`SHOP_FORMATS`; of the design scene only the keys of
    ``design``, ``export``, ``errors``, ``edm``, ``inspection`` and
    ``budget`` whose values differ from the defaults, less every key the
    loader would call without effect with those formats; under ``model = "drive"``
    the model and the drive's sections (:func:`_carry_drive`); then the chosen
    ``[modification]`` (zero amounts left out). Written by ``tomli_w``, so
    every string is escaped (a scene or file name cannot add a line); the
    only path, ``measured_profile``, is relative to ``folder`` (where the
    file is written), so the same scene gives the same bytes anywhere.
    """
    import os
    from pathlib import Path

    import tomli_w

    from corr_cad.run.scene.scene_schema import SCHEMA

    formats = _shop_formats()
    data: dict = {}
    for section in _CARRIED:
        vals = scene.source.get(section, {})
        keys = SCHEMA.get(section, {})
        kept = {k: v for k, v in vals.items() if k in keys and v != keys[k].default}
        if section == "errors" and "measured_profile" in kept:
            path = Path(scene.measured_profile).resolve()
            try:
                kept["measured_profile"] = os.path.relpath(path, Path(folder or ".").resolve())
            except ValueError:  # another drive: no relative path exists
                kept["measured_profile"] = str(path)
        if section == "export":
            kept.pop("formats", None)
            kept = {"formats": formats, **kept}
        if kept:
            data[section] = kept
    data = _without_no_effect(data, tuple(formats))
    _carry_drive(scene, data)
    mod = {
        k: v for k, v in (("equidistant_mm", equidistant_mm), ("shift_mm", shift_mm)) if v != 0.0
    }
    if normal_table is not None:  # beside modified.toml in the output folder
        mod["normal_table"] = normal_table
    data["modification"] = mod
    head = [
        "# The scene of the modification corr-cad designed ([modification.design] of the",
        "# scene in this folder's manifest.json): run it for the shop files,",
        "#   corr-cad run modified.toml --out shop",
        "# Only keys that differ from the defaults are listed.",
    ]
    if "step" not in formats:
        head.append("# step left out: Open CASCADE is not installed (pip install -e '.[step]')")
    return "\n".join(head) + "\n\n" + tomli_w.dumps(data)


def range_edges(md: dict, chosen: dict) -> list[str]:
    """The chosen amounts that lie at the end of their ``[modification.design]`` range.

    The search never looked beyond: the best may lie there. The top of a range
    always counts; its bottom unless it is 0 (no modification of that family,
    a natural end). A range of one value (``steps = 1`` or equal ends) never.

    >>> md = {"family": "equidistant+shift", "equidistant_range_mm": [0.0, 0.03],
    ...       "shift_range_mm": [-0.01, 0.02]}
    >>> edge = range_edges(md, {"equidistant_mm": 0.0, "shift_mm": 0.02})[0]
    >>> edge.startswith("shift_mm = 0.02 at the top of shift_range_mm = [-0.01, 0.02]")
    True
    >>> edge.endswith("e.g. shift_range_mm = [-0.01, 0.035]")
    True
    """
    from corr_cad.figure_text import figure

    family = md["family"]
    amounts = {"equidistant_range_mm": [chosen["equidistant_mm"]]}
    if family == "equidistant+shift":
        amounts["shift_range_mm"] = [chosen["shift_mm"]]
    if family == "free":  # every control point runs over the equidistant range
        amounts["equidistant_range_mm"] = list(chosen.get("normal_mm", []))
    out = []
    for key, values in amounts.items():
        lo, hi = (float(v) for v in md[key])
        if not hi > lo or md.get("steps", 2) < 2:
            continue
        name = key.replace("_range", "") if family != "free" else "normal_mm"
        span = hi - lo
        for v in values:
            if v >= hi - 1e-9 * span:
                wider = f"[{figure(lo)}, {figure(hi + 0.5 * span)}]"
                end = "top"
            elif v <= lo + 1e-9 * span and lo != 0.0:
                wider = f"[{figure(lo - 0.5 * span)}, {figure(hi)}]"
                end = "bottom"
            else:
                continue
            out.append(
                f"{name} = {figure(v)} at the {end} of {key} = [{figure(lo)}, {figure(hi)}]; "
                f"widen it, e.g. {key} = {wider}"
            )
            break
    return out


def _final_folder(out):
    """The folder the run's files end up in: the target of a CLI run's staging folder."""
    from corr_cad.run.folder.outputs import _is_stage

    return out.parent if _is_stage(out) else out


def _design_drive(ctx) -> dict | None:
    """The design's ``drive`` argument under ``model = "drive"`` (None: the paper's row):
    row B's own errors as given (the design adds each candidate), the bearings, the law,
    and the nominal drive's crankshaft and elastic bodies where it has them."""
    from corr_cad.run.stages.context import chain_kwargs

    s = ctx.scene
    if not s.solver.drive:
        return None
    return {
        "errors_b": s.errors_b,
        "bearing": s.bearing,
        "bearing_b": s.bearing_b,
        "contact_model": s.solver.contact_model,
        **chain_kwargs(ctx),
    }


def modification_design(ctx: RunContext) -> None:
    """Format ``modification``: search ``[modification.design]``; modification.json,
    modification_tradeoff.png and modified.toml; exit 1 when the targets are unmet."""
    from corr_cad.export.files import write_json, writing
    from corr_cad.export.modification_plots import tradeoff_png
    from corr_cad.run.progress import Progress
    from corr_cad.run.stages.context import psi_contact_limit, raw_errors
    from corr_cad.run.stages.stages_datasheet import datasheet_spec, rated_torque_Nmm
    from corr_cad.tolerance.modification_design import design_modification

    s = ctx.scene
    md = s.modification_design
    steps = md["steps"]
    n = {"equidistant": steps, "equidistant+shift": steps**2, "free": steps**4}[md["family"]]
    bar = Progress(n, "      modification design", "candidates")

    def tick(done: int, total: int) -> None:
        bar.update(done - bar.done)

    res = design_modification(
        s.design,
        s.tolerances,
        family=md["family"],
        objective=md["objective"],
        target_backlash_arcmin=md["target_backlash_arcmin"],
        max_binding_probability=md["max_binding_probability"],
        crank_moment=rated_torque_Nmm(s) / s.design.roller_count,
        equidistant_mm=(*md["equidistant_range_mm"], steps),
        shift_mm=(*md["shift_range_mm"], steps),
        backlash_percentile=md["backlash_percentile"],
        samples=md["samples"],
        seed=md["seed"],
        positions=md["positions"],
        force_candidates=md["force_candidates"],
        base_errors=raw_errors(ctx),
        load_share=s.solver.load_share,
        psi_contact_limit=psi_contact_limit(ctx),
        executor=ctx.executor,
        progress=tick,
        datasheet_spec=datasheet_spec(s) if md["objective"] == "transmission_error" else None,
        drive=_design_drive(ctx),
    )
    bar.close()
    from corr_cad.run.stages.stages_drive import samples_chain

    chain = samples_chain(s) if s.solver.drive else None
    if chain is not None:  # the key appears with the chain only (other files keep their bytes)
        res["samples_chain"] = chain
    write_json(ctx.out / "modification.json", res)
    c = res["chosen"]
    edges = range_edges(md, c) if c is not None else []
    tradeoff_png(res, ctx.out / "modification_tradeoff.png", s.design, edges)
    table = None
    if "normal_mm" in c:  # the free family: its curve as a normal table beside modified.toml
        table = "modified_normal.csv"
        pairs = zip(c["normal_psi_deg"], c["normal_mm"], strict=True)
        rows = "\n".join(f"{p!r},{v!r}" for p, v in pairs)
        with writing(ctx.out / table) as tmp:
            tmp.write_text("psi_deg,normal_mm\n" + rows + "\n")
        ctx.files.append(table)
    with writing(ctx.out / "modified.toml") as tmp:
        tmp.write_text(
            modified_toml(s, c["equidistant_mm"], c["shift_mm"], table, _final_folder(ctx.out))
        )
    ctx.files.extend(["modification.json", "modification_tradeoff.png", "modified.toml"])
    key = f"p{int(md['backlash_percentile'])}"
    rec = {
        "met": res["met"],
        "equidistant_mm": c["equidistant_mm"],
        "shift_mm": c["shift_mm"],
        **({"normal_mm": c["normal_mm"]} if "normal_mm" in c else {}),
        f"backlash_{key}_arcmin": c["backlash_arcmin"][key]["value"],
        "binding_probability": c["binding_probability"]["value"],
    }
    if edges:  # the console's warnings (corr_cad.run.console.warnings)
        rec["at_range_edge"] = edges
    if not res["met"]:
        rec["failed"] = [f"modification design: targets unmet: {res['failed']}"]
    ctx.manifest["modification_design"] = rec
    curve = f", normal {c['normal_mm']} mm at psi 0/60/120/180" if "normal_mm" in c else ""
    ctx.progress(
        f"      modification: equidistant {c['equidistant_mm']:.4g} mm, shift "
        f"{c['shift_mm']:.4g} mm{curve}; "
        f"backlash {key} {rec[f'backlash_{key}_arcmin']:.4g} arcmin, "
        f"binding probability {rec['binding_probability']:.3g}"
        + ("" if res["met"] else f"; TARGETS UNMET: {res['failed']}")
    )
