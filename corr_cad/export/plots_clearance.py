"""``clearance.png``: the exact clearance of every roller over the cycle (one row, or the
drive's two), one panel per contact and one for the neighbours.

:func:`corr_cad.export.plots.clearance_png` titles and saves it.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import FuncFormatter  # noqa: E402

from corr_cad.figure_text import figure  # noqa: E402

__all__ = ["clearance_figure"]


def _envelope(ang, values, bins: int = 720):
    """Smallest and largest over rollers and over each of ``bins`` angle bins (exact envelope)."""
    lo, hi = values.min(axis=1), values.max(axis=1)
    n = len(ang)
    if n <= bins:
        return ang, lo, hi
    edges = np.linspace(0, n, bins + 1).astype(int)
    starts = edges[:-1]
    return ang[starts], np.minimum.reduceat(lo, starts), np.maximum.reduceat(hi, starts)


_CONTACT_NAMES = (
    ("cam", "roller vs cam"),
    ("ring", "roller vs ring, working profile"),
    ("slot", "roller vs slot walls"),
)


def _clearance_ylim(ax, lo: np.ndarray, hi: np.ndarray) -> None:
    """The band's own range, room above it for the legend; zero (interference) only when
    the band reaches near it, so a band far from zero is not squeezed into a line."""
    bottom, top = float(lo.min()), float(hi.max())
    span = max(top - bottom, 0.05 * max(abs(top), abs(bottom)), 1e-3)
    if bottom <= 2.0 * span:
        bottom = min(bottom, 0.0)
        span = max(top - bottom, 1e-3)
    ax.set_ylim(bottom - 0.15 * span, top + 0.55 * span)


def clearance_figure(clr, rows: dict | None = None, summary: dict | None = None, note: str = ""):
    """``(figure, title)``: exact clearances over the cycle, one panel per contact and one
    for the neighbours (``plots.clearance_png`` adds the title and the design line).

    Each panel shows the band over all rollers at each crank angle: its lower
    edge (smallest clearance, solid: interference when negative) and its upper
    edge (largest clearance, dashed: the backlash side, free play of the
    loosest roller), on the band's own range (zero, the interference line, in
    view when the band comes near it), the legend above the band. Values
    within 1e-9 mm of zero (the closed forms' round-off) are drawn as 0; a
    contact that is exact everywhere says so in words instead of drawing three
    lines on the zero line. Contacts in um; the neighbours' gap (the space
    between two rollers of a row, never a contact) in mm once it passes 1 mm.

    ``rows`` (the drive): ``{"A": clr_a, "B": clr_b}``, both rows drawn (row B
    dotted, hatched), each extreme named with its row; ``summary`` (the
    manifest's ``clearance``, with ``rows``): the roller and crank angle of
    each extreme; ``note``: a line under the title (the bearings' free play).
    """
    rows = rows or {"": clr}
    sums = (summary or {}).get("rows") or ({"": summary} if summary else {})
    ang = np.degrees(next(iter(rows.values())).crank_angles)
    order = np.argsort(ang)
    ang = ang[order]
    fig, axes = plt.subplots(4, 1, figsize=(9, 10.5), sharex=True)
    drive = len(rows) > 1

    def where(row: str, name: str, kind: str) -> str:
        got = (sums.get(row) or {}).get(name)
        if not got:
            return ""
        return f"roller {got[f'{kind}_roller']}, {got[f'{kind}_at_crank_angle_deg']:g} deg"

    for ax, (i, (name, what)) in zip(axes, enumerate(_CONTACT_NAMES), strict=False):
        arrays = {row: getattr(c, name)[order] for row, c in rows.items()}
        um = {row: np.where(np.abs(a) < 1e-9, 0.0, a) * 1e3 for row, a in arrays.items()}
        ax.axhline(0.0, color="k", lw=0.8)
        if not any(np.any(a) for a in um.values()):
            x, lo, _ = _envelope(ang, next(iter(um.values())))
            both = " of both rows" if drive else ""
            ax.plot(x, lo, color=f"C{i}", lw=1.2, label=f"every roller{both}: 0 (no play)")
            ax.set_ylim(-1.0, 1.0)
            worst = max(float(np.abs(a).max()) for a in arrays.values())
            ax.text(
                0.5,
                0.72,
                f"exact contact: every roller{both} at every position within "
                f"{worst:.2g} mm (round-off)",
                transform=ax.transAxes,
                ha="center",
                fontsize=8,
                bbox=dict(facecolor="white", edgecolor="0.7"),
            )
        else:
            los, his = [], []
            for j, (row, a) in enumerate(um.items()):
                x, lo, hi = _envelope(ang, a)
                los.append(lo)
                his.append(hi)
                tag = f"row {row} " if row else ""
                dotted = j == 1
                ax.fill_between(
                    x,
                    lo,
                    hi,
                    color=f"C{i}",
                    alpha=0.12 if dotted else 0.2,
                    lw=0,
                    hatch="///" if dotted else None,
                    label=f"band: all rollers{' of row ' + row if row else ''}",
                )
                w_lo, w_hi = where(row, name, "min"), where(row, name, "max")
                ax.plot(
                    x,
                    lo,
                    color=f"C{i}",
                    lw=1.2,
                    ls=":" if dotted else "-",
                    label=f"{tag}smallest {figure(float(a.min()))} um"
                    + (f" ({w_lo})" if w_lo else ""),
                )
                ax.plot(
                    x,
                    hi,
                    color=f"C{i}",
                    lw=1.0,
                    ls=(0, (1, 1)) if dotted else "--",
                    label=f"{tag}largest {figure(float(a.max()))} um"
                    + (f" ({w_hi})" if w_hi else "")
                    + ", backlash side",
                )
            _clearance_ylim(ax, np.concatenate(los), np.concatenate(his))
        ax.set_ylabel("clearance [um]")
        ax.set_title(f"{what} (negative: interference)", fontsize=9)
        ax.legend(fontsize=7, loc="upper center", ncol=2 if drive else 3, frameon=False)
    ax = axes[3]
    gaps = {row: c.neighbour[order] * 1e3 for row, c in rows.items()}
    mm = max(float(np.max(g)) for g in gaps.values()) >= 1000.0
    unit, scale = ("mm", 1e-3) if mm else ("um", 1.0)
    los, his = [], []
    for j, (row, g) in enumerate(gaps.items()):
        x, lo, hi = _envelope(ang, g * scale)
        los.append(lo)
        his.append(hi)
        tag = f"row {row} " if row else ""
        ax.fill_between(x, lo, hi, color="C3", alpha=0.2, lw=0, hatch="///" if j else None,
                        label=f"band: all rollers{' of row ' + row if row else ''}")  # fmt: skip
        ax.plot(x, lo, color="C3", lw=1.2, ls=":" if j else "-",
                label=f"{tag}smallest {figure(float(lo.min()))} {unit}")  # fmt: skip
        ax.plot(x, hi, color="C3", lw=0.8, ls=(0, (1, 1)) if j else "--",
                label=f"{tag}largest {figure(float(hi.max()))} {unit}")  # fmt: skip
    _clearance_ylim(ax, np.concatenate(los), np.concatenate(his))
    ax.set_title(
        "roller vs its neighbours in the row: the space between two rollers (never a contact)"
        if mm
        else "roller vs its neighbours",
        fontsize=9,
    )
    ax.set_ylabel(f"gap [{unit}]" if mm else "clearance [um]")
    ax.set_xlabel("crank angle relative to the frame [deg]")
    ax.legend(fontsize=7, loc="upper center", ncol=2 if drive else 3, frameon=False)
    for a in axes:
        a.yaxis.set_major_formatter(FuncFormatter(lambda v, _pos: figure(v)))
    which = "rows A and B" if drive else "row A"
    title = f"Exact clearance over {len(ang)} crank positions ({which})"
    note = note.replace("; ", "\n")  # one clause a line
    top = 0.9 - 0.018 * (note.count("\n") + 1) if note else 0.9
    fig.subplots_adjust(left=0.11, right=0.97, top=top, bottom=0.06, hspace=0.35)
    return fig, title + (f"\n{note}" if note else "")
