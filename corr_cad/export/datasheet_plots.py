"""The datasheet's figures: the hysteresis curve and the transmission error (PNG).

Drawn as the RV catalogues draw them: windup (torsion angle, arcmin) across,
output torque up, the lost-motion band, the backlash and the rigidity slope
marked. Byte-deterministic like every figure (:mod:`corr_cad.export.plots`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from corr_cad.export.plots import _save, _title, plt
from corr_cad.geometry.design import GearDesign
from corr_cad.mechanics.datasheet import Datasheet
from corr_cad.mechanics.windup import ARCMIN_PER_RAD, ARCSEC_PER_RAD, NMM_PER_NM

__all__ = ["MAX_CURVES", "hysteresis_png", "transmission_error_png"]

#: Most grey curves drawn (evenly spread over the positions; the worst one always in blue).
MAX_CURVES = 200


def _curve(ds: Datasheet, j: int) -> tuple[np.ndarray, np.ndarray]:
    """(windup arcmin, torque N*m) of position ``j`` in the order -T_R .. -0, +0 .. +T_R."""
    return ds.windup[:, j] * ARCMIN_PER_RAD, ds.torques / NMM_PER_NM


def _marks(ax, ds: Datasheet, j: int, zoom: bool) -> None:
    """The lost-motion band and, near zero torque, the lost motion and the backlash; on the
    full curve, the rigidity secant."""
    sp = ds.spec
    T_R = sp.rated_torque / NMM_PER_NM
    b = sp.lost_motion_band
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
        ax.text(
            0.5 * (lm_lo + lm_hi),
            2.3 * b * T_R,
            f"lost motion {lm_hi - lm_lo:.4g} arcmin (between $\\pm${100 * b:g} % $T_R$)",
            color="C1",
            ha="center",
            va="bottom",
            fontsize=8,
        )
        bl_lo, bl_hi = ds.at(-0.0)[j] * ARCMIN_PER_RAD, ds.at(0.0)[j] * ARCMIN_PER_RAD
        ax.plot([bl_lo, bl_hi], [0.0, 0.0], color="C3", lw=3, solid_capstyle="butt", zorder=4)
        ax.text(
            0.5 * (bl_lo + bl_hi),
            -1.3 * b * T_R,
            f"backlash {bl_hi - bl_lo:.4g} arcmin (at zero torque)",
            color="C3",
            ha="center",
            va="top",
            fontsize=8,
        )
        return
    t1, t2 = sp.rigidity_range
    x1, x2 = ds.at(t1)[j] * ARCMIN_PER_RAD, ds.at(t2)[j] * ARCMIN_PER_RAD
    k = (t2 - t1) * T_R / (x2 - x1)
    xs = np.array([x1 - 0.6 * (x2 - x1), x2 + 0.15 * (x2 - x1)])
    ax.plot(xs, t1 * T_R + k * (xs - x1), color="C2", lw=4, alpha=0.45, zorder=1)
    ax.plot([x1, x2], [t1 * T_R, t2 * T_R], "o", color="C2", ms=5, zorder=5)
    series = sp.series_rigidity_Nm_per_arcmin
    contact = float(ds.rigidity(contact_only=True)[0, j])
    text = f"rigidity {k:.4g} N*m/arcmin\n(secant {100 * t1:g}-{100 * t2:g} % $T_R$"
    text += f"; contacts alone {contact:.4g})" if series is not None else "; contacts only)"
    ax.text(x1, t2 * T_R, text + "  ", color="C2", ha="right", va="top", fontsize=8)
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
    ds: Datasheet, path: Path, design: GearDesign | None = None, note: str = ""
) -> Path:
    """The torque-windup curve at every position, the worst one marked (largest lost motion)."""
    T_R = ds.spec.rated_torque / NMM_PER_NM
    j = int(np.argmax(ds.lost_motion()))
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.4))
    b = ds.spec.lost_motion_band
    for ax, zoom in zip(axes, (False, True), strict=True):
        P = ds.windup.shape[1]
        for i in np.unique(np.linspace(0, P - 1, min(P, MAX_CURVES)).round().astype(int)):
            x, y = _curve(ds, i)
            ax.plot(x, y, color="0.75", lw=0.6)
        x, y = _curve(ds, j)
        ax.plot(x, y, color="C0", lw=1.6, marker="." if zoom else None, ms=4)
        ax.axhline(0.0, color="0.3", lw=0.5)
        ax.axvline(0.0, color="0.3", lw=0.5)
        _marks(ax, ds, j, zoom)
        ax.set_xlabel("output windup (torsion angle) [arcmin]")
        ax.set_ylabel("output torque [N*m]")
        ax.grid(alpha=0.3)
        sec = ax.secondary_yaxis(
            "right", functions=(lambda t: 100 * t / T_R, lambda p: p * T_R / 100)
        )
        sec.set_ylabel("% of rated torque $T_R$")
    axes[0].set_title(
        f"-$T_R$ .. +$T_R$, $T_R$ = {T_R:.4g} N*m; grey: {ds.windup.shape[1]} positions over "
        f"{ds.span.split(' (')[0]}\nblue: the position of the largest lost motion",
        fontsize=9,
    )
    y = 4.0 * b * T_R
    keep = np.abs(ds.torques / NMM_PER_NM) <= y * (1 + 1e-9)
    x = ds.windup[keep] * ARCMIN_PER_RAD
    pad = 0.1 * max(float(np.ptp(x)), 1e-6)
    axes[1].set_xlim(float(x.min()) - pad, float(x.max()) + pad)
    axes[1].set_ylim(-y, y)
    axes[1].set_title(f"near zero torque (+-{400 * b:g} % $T_R$)", fontsize=9)
    title = "Hysteresis curve: output torque against windup, input locked, ring fixed"
    title += "\nloading and unloading branches coincide: no friction in the model"
    if note:
        title += f"; {note}"
    _title(fig, title, design, None)
    fig.tight_layout()
    return _save(fig, path)


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
        ptp = float(np.ptp(y))
        mid = 0.5 * (float(y.max()) + float(y.min()))
        half = max(0.6 * ptp, 0.5)  # a flat curve stays flat: at least +-0.5 arcsec shown
        for ax, sel in ((axes[row, 0], slice(None)), (axes[row, 1], first)):
            ax.plot(x[sel], y[sel], color=colour, lw=0.8)
            ax.set_ylim(mid - half, mid + half)
            ax.grid(alpha=0.3)
        axes[row, 0].set_ylabel("TE [arcsec]")
        axes[row, 0].set_title(
            f"{name}: peak-to-peak {ptp:.4g} arcsec (mean {float(y.mean()):.4g} arcsec)",
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
        f"driving torque {T:.4g} N*m (forward: the load resists + rotation)"
    )
    if note:
        title += f"\n{note}"
    _title(fig, title, design, None)
    fig.tight_layout()
    return _save(fig, path)
