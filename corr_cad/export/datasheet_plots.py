"""The datasheet's figures: the hysteresis curve, the transmission error and the
selective assembly (PNG).

Drawn as the RV catalogues draw them: windup (torsion angle, arcmin) across,
output torque up, the lost-motion band, the backlash and the rigidity slope
marked. Byte-deterministic like every figure (:mod:`corr_cad.export.plots`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import FuncFormatter

from corr_cad.export.plots import _save, _title, plt
from corr_cad.figure_text import figure
from corr_cad.geometry.design import GearDesign
from corr_cad.mechanics.datasheet import Datasheet
from corr_cad.mechanics.row.windup import ARCMIN_PER_RAD, ARCSEC_PER_RAD, NMM_PER_NM

__all__ = [
    "MAX_CURVES",
    "TE_FLAT_ARCSEC",
    "hysteresis_png",
    "transmission_error_png",
    "assembly_png",
]

#: Half height (arcsec) of a transmission-error axis at the least: a curve flatter than
#: this (round-off) is drawn flat, not blown up.
TE_FLAT_ARCSEC = 1e-3

#: Most position curves drawn (evenly spread over the positions; the worst one always in blue).
MAX_CURVES = 200


def _curve(ds: Datasheet, j: int) -> tuple[np.ndarray, np.ndarray]:
    """(windup arcmin, torque N*m) of position ``j`` in the order -T_R .. -0, +0 .. +T_R."""
    return ds.windup[:, j] * ARCMIN_PER_RAD, ds.torques / NMM_PER_NM


#: Behind a label that the windup curves cross near zero torque: the curves
#: stop short of its letters.
_LABEL_BOX = {
    "boxstyle": "square,pad=0.15",
    "facecolor": "white",
    "edgecolor": "none",
    "alpha": 0.85,
}


def _marks(ax, ds: Datasheet, j: int, zoom: bool, stage: str = "", elastic: bool = False) -> None:
    """The lost-motion band; near zero torque the lost motion (on position ``j``, the
    largest) and the backlash (on the position of the largest); on the full curve the
    rigidity secant on the position and branch of the catalogue (least) rigidity.

    Every number is the datasheet's catalogue figure (``datasheet.json``, the console and
    the checks print the same)."""
    sp = ds.spec
    T_R = sp.rated_torque / NMM_PER_NM
    b = sp.lost_motion_band
    fig_ = ds.figures()
    for y in (-b * T_R, b * T_R):
        ax.axhline(y, color="C1", lw=0.8, ls="--")
    if zoom:
        lm_lo, lm_hi = ds.at(-b)[j] * ARCMIN_PER_RAD, ds.at(b)[j] * ARCMIN_PER_RAD
        ax.plot([lm_lo, lm_hi], [-b * T_R, b * T_R], "o", color="C1", ms=5, zorder=5)
        for x, y in ((lm_lo, -b * T_R), (lm_hi, b * T_R)):
            ax.plot([x, x], [y, 2.2 * b * T_R], color="C1", lw=0.8, ls=":")
        ax.annotate(
            "",
            xy=(lm_hi, 2.2 * b * T_R),
            xytext=(lm_lo, 2.2 * b * T_R),
            arrowprops={"arrowstyle": "<->", "color": "C1", "lw": 1.2},
        )
        lm = fig_["lost_motion_arcmin"]["max"]
        ax.text(
            0.5 * (lm_lo + lm_hi),
            2.3 * b * T_R,
            f"{stage}lost motion {figure(lm)} arcmin (between $\\pm${100 * b:g} % $T_R$)",
            color="C1",
            ha="center",
            va="bottom",
            fontsize=8,
            bbox=_LABEL_BOX,
            zorder=6,
        )
        jb = int(np.argmax(ds.backlash()))
        bl_lo, bl_hi = ds.at(-0.0)[jb] * ARCMIN_PER_RAD, ds.at(0.0)[jb] * ARCMIN_PER_RAD
        ax.plot([bl_lo, bl_hi], [0.0, 0.0], color="C3", lw=3, solid_capstyle="butt", zorder=4)
        ax.text(  # on the red bar it names, between it and the band line above
            0.5 * (bl_lo + bl_hi),
            0.2 * b * T_R,
            f"{stage}backlash {figure(fig_['backlash_arcmin']['max'])} arcmin (at zero torque)",
            color="C3",
            ha="center",
            va="bottom",
            fontsize=8,
            bbox=_LABEL_BOX,
            zorder=6,
        )
        return
    t1, t2 = sp.rigidity_range
    rig = ds.rigidity()  # (2, P): branches +T, -T
    branch, jr = np.unravel_index(int(np.argmin(rig)), rig.shape)
    sign = 1.0 if branch == 0 else -1.0
    x1, x2 = (ds.at(sign * t)[jr] * ARCMIN_PER_RAD for t in (t1, t2))
    y1, y2 = sign * t1 * T_R, sign * t2 * T_R
    k = float(rig[branch, jr])  # = the catalogue figure, the least over branches and positions
    # The secant from below T_1 to T_2: never past the rated torque.
    xs = np.array([x1 - 0.6 * (x2 - x1), x2])
    ax.plot(xs, y1 + (y2 - y1) / (x2 - x1) * (xs - x1), color="C2", lw=4, alpha=0.45, zorder=1)
    ax.plot([x1, x2], [y1, y2], "o", color="C2", ms=5, zorder=5)
    text = (
        f"rigidity {figure(k)} N*m/arcmin\n(secant {figure(t1 * T_R)} to {figure(t2 * T_R)} N*m"
        f" = {100 * t1:g}-{100 * t2:g} % $T_R$"
    )
    if sp.series_rigidity_Nm_per_arcmin is not None:
        contact = float(ds.rigidity(contact_only=True)[branch, jr])
        alone = "contacts and elastic bodies" if elastic else "contacts alone"
        text += f";\n{alone} {figure(contact)} N*m/arcmin)"
    else:
        text += ";\ncontacts, elastic rings, frame, cams)" if elastic else "; contacts only)"
    # In the upper left quadrant, which the curve never enters (+T: windup > 0).
    ax.text(0.02, 0.97, text, transform=ax.transAxes, color="C2", ha="left", va="top", fontsize=8)
    ax.text(
        0.98,
        0.04,
        "backlash and lost motion: see the right panel",
        transform=ax.transAxes,
        ha="right",
        fontsize=8,
        color="0.35",
    )


def hysteresis_png(
    ds: Datasheet,
    path: Path,
    design: GearDesign | None = None,
    note: str = "",
    friction_width_arcmin: float | None = None,
    loop: dict | None = None,
    whole_drive: dict | None = None,
    elastic: bool = False,
) -> Path:
    """The torque-windup curve at every position, the worst one marked (largest lost motion).
    ``elastic``: the rigidity's label names the elastic bodies (``[solver] bodies``).

    ``whole_drive`` (with ``[first_stage]``: ``datasheet.json`` ``whole_drive``): the curves
    are the second stage's (crank locked); the title gives the whole drive's backlash and
    lost motion, the first stage's backlash at the output included.

    Each position in its own colour (by output angle), drawn over the marked one
    (black, dashed), so that none hides another. The curves are the frictionless
    windup; ``friction_width_arcmin`` (with ``[friction]``: the loop's largest width
    at +-T_R, ``datasheet.json`` ``hysteresis_width_at_rated_arcmin``) is named in
    the title instead of the line that the branches coincide, and ``loop`` (the
    branches at the position of that width, ``hysteresis.csv``) is drawn in red.
    """
    T_R = ds.spec.rated_torque / NMM_PER_NM
    j = int(np.argmax(ds.lost_motion()))
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.6))
    b = ds.spec.lost_motion_band
    P = ds.windup.shape[1]
    shown = np.unique(np.linspace(0, P - 1, min(P, MAX_CURVES)).round().astype(int))
    colours = plt.get_cmap("viridis")(np.linspace(0.0, 0.9, len(shown)))
    for ax, zoom in zip(axes, (False, True), strict=True):
        x, y = _curve(ds, j)
        ax.plot(x, y, color="k", lw=2.2, alpha=0.35, zorder=2)
        for c, i in zip(colours, shown, strict=True):
            x, y = _curve(ds, i)
            ax.plot(x, y, color=c, lw=0.9, zorder=3)
        x, y = _curve(ds, j)
        ax.plot(x, y, color="k", lw=1.0, ls=(0, (4, 3)), marker="." if zoom else None, ms=4,
                zorder=4)  # fmt: skip
        if loop is not None:
            t = loop["torques"] / NMM_PER_NM
            ax.plot(loop["rising"] * ARCMIN_PER_RAD, t, color="C3", lw=1.3, zorder=5)
            ax.plot(loop["falling"] * ARCMIN_PER_RAD, t, color="C3", lw=1.3, ls="-.",
                    zorder=5)  # fmt: skip
        ax.axhline(0.0, color="0.3", lw=0.5)
        ax.axvline(0.0, color="0.3", lw=0.5)
        _marks(ax, ds, j, zoom, "second stage: " if whole_drive else "", elastic)
        ax.set_xlabel("output windup (torsion angle) [arcmin]")
        ax.set_ylabel("output torque [N*m]")
        ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _pos: figure(v)))
        ax.grid(alpha=0.3)
        sec = ax.secondary_yaxis(
            "right", functions=(lambda t: 100 * t / T_R, lambda p: p * T_R / 100)
        )
        sec.set_ylabel("% of rated torque $T_R$")
    span = ds.span.split(" (")[0]
    handles = [
        Line2D([], [], color=colours[len(colours) // 2], lw=0.9),
        Line2D([], [], color="k", lw=1.0, ls=(0, (4, 3))),
    ]
    labels = [
        f"each of {P} positions over {span}\n(colour: output angle, dark first)",
        "the position of the largest lost motion",
    ]
    if loop is not None:
        at = f"{np.degrees(loop['output_angle']):.2f}"
        handles += [Line2D([], [], color="C3", lw=1.3), Line2D([], [], color="C3", lw=1.3, ls="-.")]
        labels += [
            f"torque rising, with friction (output angle {at} deg)",
            "torque falling, with friction",
        ]
    axes[0].legend(
        handles,
        labels,
        loc="lower right",
        bbox_to_anchor=(1.0, 0.09),
        fontsize=8,
    )
    axes[0].set_title(f"-$T_R$ .. +$T_R$, $T_R$ = {figure(T_R)} N*m", fontsize=9)
    y = 4.0 * b * T_R
    keep = np.abs(ds.torques / NMM_PER_NM) <= y * (1 + 1e-9)
    x = ds.windup[keep] * ARCMIN_PER_RAD
    if loop is not None:
        near = np.abs(loop["torques"] / NMM_PER_NM) <= y * (1 + 1e-9)
        x = np.concatenate(
            [x.ravel(), *(loop[k][near] * ARCMIN_PER_RAD for k in ("rising", "falling"))]
        )
    pad = 0.1 * max(float(np.ptp(x)), 1e-6)
    axes[1].set_xlim(float(x.min()) - pad, float(x.max()) + pad)
    axes[1].set_ylim(-y, y)
    axes[1].set_title(f"near zero torque (+-{400 * b:g} % $T_R$)", fontsize=9)
    title = "Hysteresis curve: output torque against windup, input locked, ring fixed"
    if friction_width_arcmin is None:
        title += "\nloading and unloading branches coincide: no friction in the model"
    else:
        title += (
            "\nthe frictionless windup; [friction] opens the loop (red) by up to "
            f"{figure(friction_width_arcmin)} arcmin at +-$T_R$ (datasheet.json)"
        )
    if note:
        title += f"; {note}"
    if whole_drive:
        title += (
            "\ncurves and marks: the second stage, crank locked; the whole drive, pinion "
            f"held: backlash {figure(whole_drive['backlash_arcmin']['value'])} arcmin, lost "
            f"motion {figure(whole_drive['lost_motion_arcmin']['value'])} arcmin (first stage "
            "included)"
        )
    _title(fig, title, design, None)
    fig.tight_layout()
    return _save(fig, path)


def _revolution(ax, x: np.ndarray, y: np.ndarray, colour: str) -> None:
    """One output revolution: with more than four points a degree (a ripple no line
    resolves across the panel), the band from least to largest per degree and its mean;
    else the curve itself."""
    k = np.floor(x).astype(int)
    if len(x) <= 4 * 360:
        ax.plot(x, y, color=colour, lw=0.8)
        return
    edges = np.unique(k)
    lo = np.array([y[k == e].min() for e in edges])
    hi = np.array([y[k == e].max() for e in edges])
    mean = np.array([y[k == e].mean() for e in edges])
    centre = edges + 0.5
    ax.fill_between(
        centre, lo, hi, color=colour, alpha=0.3, lw=0, label="least to largest per degree"
    )
    ax.plot(centre, mean, color=colour, lw=1.0, label="mean per degree")
    ax.legend(fontsize=7, loc="lower right", ncol=2, framealpha=0.9)


def transmission_error_png(
    ds: Datasheet, path: Path, design: GearDesign | None = None, note: str = ""
) -> Path:
    """Forward and reverse transmission error over one output revolution, arcsec.

    ``note``: appended to the title (which ring, for a measured one).

    Right: the first tooth pitch of output (``360/z`` deg), where every roller
    passes the loaded zone once.
    """
    x = np.degrees(ds.te_output_angles)
    T = ds.spec.transmission_error_torque_band * ds.spec.rated_torque / NMM_PER_NM
    fig, axes = plt.subplots(
        2, 2, figsize=(13, 6.4), sharey="row", gridspec_kw={"width_ratios": [3, 1]}
    )
    pitch = 360.0 / design.tooth_count if design is not None else 360.0 / 25
    first = x <= pitch
    for row, name, te, colour in (
        (0, "forward", ds.te_forward, "C0"),
        (1, "reverse", ds.te_reverse, "C3"),
    ):
        y = te * ARCSEC_PER_RAD
        ptp, mean = float(np.ptp(y)), float(y.mean())
        y = y - mean  # the ripple about this direction's own mean, on its own scale
        mid = 0.5 * (float(y.max()) + float(y.min()))
        half = max(0.6 * ptp, TE_FLAT_ARCSEC)  # a flat curve stays flat
        _revolution(axes[row, 0], x, y, colour)
        axes[row, 1].plot(x[first], y[first], color=colour, lw=0.8)
        for ax in axes[row]:
            ax.set_ylim(mid - 1.35 * half, mid + half)  # room for the legend below the band
            ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _pos: figure(v)))
            ax.grid(alpha=0.3)
        axes[row, 0].set_ylabel("TE - mean [arcsec]")
        axes[row, 0].set_title(
            f"{name}: peak-to-peak {figure(ptp)} arcsec about its mean {figure(mean)} arcsec "
            "(the windup at the driving torque)",
            fontsize=9,
        )
        axes[row, 1].set_title(f"{name}, first tooth pitch", fontsize=9)
    axes[1, 0].set_xlabel("output angle [deg] (ring fixed)")
    axes[1, 1].set_xlabel("output angle [deg]")
    for r in (0, 1):
        axes[r, 0].set_xlim(0.0, 360.0)
        axes[r, 1].set_xlim(0.0, pitch)
    title = (
        "Transmission error theta_out - theta_in/(z+1), one output revolution, "
        f"driving torque {figure(T)} N*m (forward: the load resists + rotation)"
    )
    if note:
        title += f"\n{note}"
    _title(fig, title, design, None)
    fig.tight_layout()
    return _save(fig, path)


def assembly_png(res: dict, path: Path, design: GearDesign | None = None) -> Path:
    """Selective assembly: each roller class's backlash and binding against the target.

    ``res``: ``assembly.json``. Left: the backlash of every class (max over the
    positions, the catalogue figure; the bar from the least), the target line,
    the chosen class ringed; a class that binds is drawn hatched red. Right:
    the binding measure (``interference_um``: > 0 binds; <= 0 the room on the
    tightest roller) against zero.
    """
    rows = res["classes"]
    cls = np.array([r["class_um"] for r in rows])
    bmax = np.array([r["backlash_arcmin"]["max"] for r in rows])
    bmin = np.array([r["backlash_arcmin"]["min"] for r in rows])
    binds = np.array([r["binds"] for r in rows])
    inter = np.array([r["interference_um"] for r in rows])
    target = res["target_backlash_arcmin"]
    chosen = res.get("chosen_class_um")
    inter = np.where(np.abs(inter) < 1e-6, 0.0, inter)  # below 1e-9 mm: exact contact
    width = 0.6 * (float(np.min(np.diff(np.sort(cls)))) if len(cls) > 1 else 1.0)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 5.2))
    top = max(float(bmax.max()), target)
    for k, row in enumerate(rows):
        style = {"color": "C2" if row["meets_target"] else "C0", "alpha": 0.75}
        if binds[k]:
            style = {"facecolor": "C3", "alpha": 0.35, "hatch": "//", "edgecolor": "C3"}
        if cls[k] == chosen:
            style.update(edgecolor="k", lw=2.0)
        a1.bar(cls[k], bmax[k], width=width, **style)
        a2.bar(cls[k], inter[k], width=width, **style)
        a1.plot([cls[k]] * 2, [bmin[k], bmax[k]], color="k", lw=1.0,
                marker="_", ms=8)  # fmt: skip
        note = "binds" if binds[k] else figure(bmax[k])
        if cls[k] == chosen:
            note += "\nchosen"
        a1.annotate(note, (cls[k], bmax[k]), xytext=(0, 3), textcoords="offset points",
                    ha="center", va="bottom", fontsize=7)  # fmt: skip
        a2.annotate(figure(inter[k]) if inter[k] else "0 (exact contact)", (cls[k], inter[k]),
                    xytext=(0, 3 if inter[k] >= 0 else -3), textcoords="offset points",
                    ha="center", va="bottom" if inter[k] >= 0 else "top", fontsize=7)  # fmt: skip
    for ax in (a1, a2):
        ax.set_xticks(cls, [f"{c:+g}" for c in cls])
        ax.set_xlabel("roller class [um] (radius deviation)")
        ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _pos: figure(v)))
        ax.grid(axis="y", alpha=0.3)
    a1.set_ylim(0.0, 1.2 * top)
    a1.axhline(target, color="C1", ls="--", lw=1.5)
    a1.set_ylabel("backlash [arcmin]")
    a2.axhline(0.0, color="k", lw=0.8)
    a2.margins(y=0.15)
    a2.set_ylabel("binding interference [um] (> 0: binds)")
    handles = [
        Patch(color="C2", alpha=0.75, label="meets the target, fits"),
        Patch(color="C0", alpha=0.75, label="fits, backlash above the target"),
        Patch(facecolor="C3", alpha=0.35, hatch="//", edgecolor="C3", label="binds"),
        Line2D([], [], color="k", marker="_", ms=8, label="least to largest over the positions"),
        Line2D([], [], color="C1", ls="--", label=f"target {figure(target)} arcmin"),
    ]
    if chosen is not None:
        handles.append(Patch(facecolor="none", edgecolor="k", lw=2.0,
                             label=f"chosen: class {chosen:+g} um"))  # fmt: skip
        verdict = f"fit roller class {chosen:+g} um"
    else:
        verdict = f"NO CLASS FITS: {res.get('reason')}"
    fig.legend(handles=handles, loc="lower center", ncol=3, fontsize=8, frameon=False)
    a1.set_title("backlash of each class against the target", fontsize=9)
    a2.set_title("binding of each class (gaps only, no force solve)", fontsize=9)
    ring = res.get("ring", "")
    _title(fig, f"Selective assembly ({ring}): {verdict}", design, None)
    fig.subplots_adjust(left=0.07, right=0.98, top=0.84, bottom=0.22, wspace=0.3)
    return _save(fig, path)
