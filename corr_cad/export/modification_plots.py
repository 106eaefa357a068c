"""``modification.png``: the normal clearance a profile modification gives along
the tooth space, per family and in total (issue 20)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402
from matplotlib.ticker import FuncFormatter  # noqa: E402

from corr_cad.export.plots import _save, _title  # noqa: E402
from corr_cad.figure_text import figure  # noqa: E402
from corr_cad.geometry.design import GearDesign  # noqa: E402

__all__ = ["modification_png", "tradeoff_png"]

_LABELS = {
    "equidistant": "equidistant",
    "shift": "shift",
    "normal_table": "normal table",
    "total": "total (the profile as cut)",
}


def modification_png(
    psi_deg: np.ndarray, curves: dict[str, np.ndarray], path: Path, design: GearDesign | None
) -> Path:
    """Clearance (um, + = clearance) against the roll angle psi, one line per family."""
    fig, ax = plt.subplots(figsize=(9, 5))
    ax.axhline(0.0, color="k", lw=0.8)
    for i, (name, c) in enumerate(curves.items()):
        um = np.asarray(c) * 1e3
        ls = "-" if name == "total" else "--"
        lw = 2.0 if name == "total" else 1.2
        color = "k" if name == "total" else f"C{i}"
        label = f"{_LABELS.get(name, name)}: {figure(um.min())} to {figure(um.max())} um"
        ax.plot(psi_deg, um, ls=ls, lw=lw, color=color, label=label)
    ax.set_xlim(-180.0, 180.0)
    ax.set_xticks(np.arange(-180, 181, 45))
    ax.set_xlabel("roll angle psi [deg] (0 tooth space, +-180 tooth tip)")
    ax.set_ylabel("normal clearance [um] (+ = clearance, material removed)")
    ax.grid(True, lw=0.4, alpha=0.5)
    ax.legend(fontsize=8, loc="best")
    _title(
        fig,
        "Profile modification: exact normal clearance to the nominal roller along the tooth space",
        design,
        None,
    )
    fig.subplots_adjust(top=0.85)
    return _save(fig, path)


def _candidate_label(r: dict) -> str:
    """``eq 0.01 / sh 0.02`` (mm), or the free family's normal values at its control points."""
    if "normal_mm" in r:
        return "n " + "/".join(figure(v) for v in r["normal_mm"])
    return f"eq {figure(r['equidistant_mm'])} / sh {figure(r['shift_mm'])}"


_OBJECTIVE_LABEL = {
    "transmission_error": "transmission error, nominal [arcsec]",
    "peak_pressure": "peak contact pressure p95 [MPa]",
}


def _objective(r: dict, obj: str) -> float:
    """A candidate's value of the search objective."""
    if obj == "transmission_error":
        return r["transmission_error_arcsec_nominal"]
    if obj == "peak_pressure":
        return r["peak_pressure_MPa"]["p95"]["value"]
    return r["min_loaded_rollers"]["p5"]["value"]


def tradeoff_png(
    res: dict, path: Path, design: GearDesign | None, edges: list[str] | None = None
) -> Path:
    """The design search: backlash against binding probability (every candidate, the
    feasible region shaded) and against the objective (the candidates solved for forces,
    each labelled with its amounts), the chosen point marked; ``edges``: the chosen
    amounts that lie at the end of their search range, flagged in red."""
    key = f"p{int(res['targets']['backlash_percentile'])}"
    target_b = res["targets"]["target_backlash_arcmin"]
    target_p = res["targets"]["max_binding_probability"]
    valid = [r for r in res["candidates"] if r.get("valid")]
    bl = np.array([r["backlash_arcmin"][key]["value"] for r in valid])
    pb = np.array([r["binding_probability"]["value"] for r in valid])
    ch = res["chosen"]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(13, 5.6))
    a1.scatter(bl, pb, s=18, c="0.5", label="candidates", zorder=3)
    a1.scatter(
        [ch["backlash_arcmin"][key]["value"]],
        [ch["binding_probability"]["value"]],
        s=120,
        facecolors="none",
        edgecolors="r",
        lw=2,
        zorder=4,
        label=f"chosen: {_candidate_label(ch)} mm",
    )
    a1.axvline(target_b, color="C1", ls="--", label=f"backlash target {figure(target_b)} arcmin")
    a1.axhline(target_p, color="C3", ls="--", label=f"binding target {figure(target_p)}")
    x0, x1 = a1.get_xlim()
    y0, y1 = a1.get_ylim()
    a1.add_patch(
        Rectangle(
            (x0, y0),
            max(target_b - x0, 0.0),
            max(target_p - y0, 0.0),
            color="C2",
            alpha=0.15,
            lw=0,
            label="feasible: both targets met",
            zorder=1,
        )
    )
    a1.set_xlim(x0, x1)
    a1.set_ylim(y0, y1)
    a1.set_xlabel(f"backlash {key} [arcmin]")
    a1.set_ylabel("binding probability")
    a1.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2)
    solved = [r for r in valid if r.get("force_solved")]
    obj = res["objective"]
    if solved:
        x = [r["backlash_arcmin"][key]["value"] for r in solved]
        y = [_objective(r, obj) for r in solved]
        a2.set_ylabel(_OBJECTIVE_LABEL.get(obj, "fewest loaded rollers p5"))
        # Different candidates, not a curve: points, each with its amounts.
        a2.scatter(x, y, s=30, color="C0", zorder=3, label="feasible, solved for forces")
        for r, xi, yi in zip(solved, x, y, strict=True):
            a2.annotate(_candidate_label(r), (xi, yi), xytext=(4, 4), textcoords="offset points",
                        fontsize=7, color="0.25")  # fmt: skip
        if ch.get("force_solved"):
            yc = _objective(ch, obj)
            a2.scatter([ch["backlash_arcmin"][key]["value"]], [yc], s=120, facecolors="none",
                       edgecolors="r", lw=2, label="chosen", zorder=4)  # fmt: skip
        a2.margins(x=0.2, y=0.15)
        lo, hi = a2.get_xlim()
        if lo < target_b:
            a2.axvspan(lo, min(target_b, hi), color="C2", alpha=0.15, lw=0, zorder=1,
                       label="backlash target met")  # fmt: skip
        a2.set_xlim(lo, hi)
        a2.yaxis.set_major_formatter(FuncFormatter(lambda v, _pos: figure(v)))
        a2.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=3)
    else:
        a2.text(0.5, 0.5, "no candidate meets both targets", ha="center", transform=a2.transAxes)
    if edges:  # at the chosen point, and the whole line (key, range, wider range) below
        a1.annotate(
            "at the edge of its search range",
            (ch["backlash_arcmin"][key]["value"], ch["binding_probability"]["value"]),
            xytext=(12, 28),
            textcoords="offset points",
            fontsize=8,
            color="C3",
            arrowprops={"arrowstyle": "->", "color": "C3"},
        )
        fig.text(0.5, 0.015, "\n".join(f"at the edge: {e}" for e in edges), ha="center",
                 va="bottom", fontsize=8, color="C3")  # fmt: skip
    a2.set_xlabel(f"backlash {key} [arcmin]")
    a2.grid(True, lw=0.4, alpha=0.5)
    a1.grid(True, lw=0.4, alpha=0.5)
    verdict = "targets met" if res["met"] else "TARGETS UNMET"
    _title(fig, f"Modification design ({res['family']}, {res['samples']} samples): {verdict}",
           design, None)  # fmt: skip
    fig.subplots_adjust(top=0.85, bottom=0.27)
    return _save(fig, path)
