"""``compliance.png``: the compliance budget of the drive's windup, by component.

Each bar is a component's windup at the rated torque (from the kinematic zero) and over
the rigidity range (the catalogue rigidity's ``T_1 .. T_2``), in arcmin, with its share;
the components the model holds rigid are listed, greyed, with the reason
(``datasheet.json`` ``compliance_budget``). Byte-deterministic like every figure.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from corr_cad.export.plots import _save, _title, plt
from corr_cad.figure_text import figure
from corr_cad.geometry.design import GearDesign

__all__ = ["compliance_png"]


def compliance_png(budget: dict, path: Path, design: GearDesign | None = None) -> Path:
    """Draw ``budget`` (``datasheet.json``'s ``compliance_budget``) into ``path``."""
    comps = budget["components"]
    shown = [k for k, v in comps.items() if v["in_model"] and v["windup_arcmin"] != 0.0]
    absent = [k for k, v in comps.items() if not v["in_model"]]
    zero = [k for k, v in comps.items() if v["in_model"] and v["windup_arcmin"] == 0.0]
    names = shown + zero + absent
    y = np.arange(len(names))[::-1]
    rated = np.array([comps[k]["windup_arcmin"] for k in names])
    branch = np.array([comps[k]["rigidity_range_arcmin"] for k in names])
    fig, ax = plt.subplots(figsize=(8.6, 0.42 * len(names) + 2.2))
    h = 0.38
    ax.barh(y + h / 2, rated, h, color="#1f77b4", label="at T_R, from the kinematic zero")
    lo, hi = budget["rigidity_range_Nm"]
    ax.barh(
        y - h / 2,
        branch,
        h,
        color="#ff7f0e",
        label=f"over the rigidity range {figure(lo)}-{figure(hi)} N*m",
    )
    top = max(float(rated.max()), 1e-12)
    for yi, k, v in zip(y, names, rated, strict=True):
        c = comps[k]
        if c["in_model"]:
            text = f"{figure(v)} arcmin ({100 * c['share']:.1f} %)"
            color = "black"
        else:
            text = c.get("note", "not in the model")
            color = "grey"
        ax.text(v + 0.01 * top, yi + h / 2, text, va="center", fontsize=8, color=color)
    ax.set_yticks(y)
    ax.set_yticklabels([k.replace("_", " ") for k in names])
    for lab, k in zip(ax.get_yticklabels(), names, strict=True):
        if not comps[k]["in_model"]:
            lab.set_color("grey")
    ax.set_xlim(0.0, 1.6 * top)
    ax.set_xlabel("windup of the output, arcmin (its share of the total in brackets)")
    ax.legend(loc="lower right", fontsize=8)
    ax.grid(axis="x", alpha=0.3)
    _title(
        fig,
        f"Compliance budget: windup {figure(budget['windup_arcmin'])} arcmin at T_R = "
        f"{figure(budget['torque_Nm'])} N*m, by component (virtual work; they add up)",
        design,
        None,
    )
    fig.tight_layout()
    return _save(fig, path)
