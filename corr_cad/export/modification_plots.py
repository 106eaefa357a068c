"""``modification.png``: the normal clearance a profile modification gives along
the tooth space, per family and in total (issue 20)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from corr_cad.export.plots import _save, _title  # noqa: E402
from corr_cad.geometry.design import GearDesign  # noqa: E402

__all__ = ["modification_png"]

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
        label = f"{_LABELS.get(name, name)}: {um.min():.4g} to {um.max():.4g} um"
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
