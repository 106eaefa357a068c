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


def tradeoff_png(res: dict, path: Path, design: GearDesign | None) -> Path:
    """The design search: backlash against binding probability (every candidate) and
    against the objective (the candidates solved for forces), the chosen point marked."""
    key = f"p{int(res['targets']['backlash_percentile'])}"
    valid = [r for r in res["candidates"] if r.get("valid")]
    bl = np.array([r["backlash_arcmin"][key]["value"] for r in valid])
    pb = np.array([r["binding_probability"]["value"] for r in valid])
    ch = res["chosen"]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 5))
    a1.scatter(bl, pb, s=18, c="0.5", label="candidates")
    a1.scatter(
        [ch["backlash_arcmin"][key]["value"]],
        [ch["binding_probability"]["value"]],
        s=120,
        facecolors="none",
        edgecolors="r",
        lw=2,
        label=f"chosen: eq {ch['equidistant_mm']:.4g} mm, shift {ch['shift_mm']:.4g} mm"
        + (f", normal {ch['normal_mm']} mm" if "normal_mm" in ch else ""),
    )
    a1.axvline(
        res["targets"]["target_backlash_arcmin"], color="C1", ls="--", label="backlash target"
    )
    a1.axhline(
        res["targets"]["max_binding_probability"], color="C3", ls="--", label="binding target"
    )
    a1.set_xlabel(f"backlash {key} [arcmin]")
    a1.set_ylabel("binding probability")
    a1.legend(fontsize=8)
    solved = [r for r in valid if r.get("force_solved")]
    obj = res["objective"]
    if solved:
        x = [r["backlash_arcmin"][key]["value"] for r in solved]
        if obj == "transmission_error":
            y = [r["transmission_error_arcsec_nominal"] for r in solved]
            a2.set_ylabel("transmission error, nominal [arcsec]")
        elif obj == "peak_pressure":
            y = [r["peak_pressure_MPa"]["p95"]["value"] for r in solved]
            a2.set_ylabel("peak contact pressure p95 [MPa]")
        else:
            y = [r["min_loaded_rollers"]["p5"]["value"] for r in solved]
            a2.set_ylabel("fewest loaded rollers p5")
        order = np.argsort(x)
        a2.plot(np.array(x)[order], np.array(y)[order], "o-", color="C0", label="feasible, solved")
        if ch.get("force_solved"):
            yc = {
                "transmission_error": ch.get("transmission_error_arcsec_nominal"),
                "peak_pressure": ch["peak_pressure_MPa"]["p95"]["value"],
                "loaded_rollers": ch["min_loaded_rollers"]["p5"]["value"],
            }[obj]
            a2.scatter([ch["backlash_arcmin"][key]["value"]], [yc], s=120, facecolors="none",
                       edgecolors="r", lw=2, label="chosen")  # fmt: skip
        a2.legend(fontsize=8)
    else:
        a2.text(0.5, 0.5, "no candidate meets both targets", ha="center", transform=a2.transAxes)
    a2.set_xlabel(f"backlash {key} [arcmin]")
    a2.grid(True, lw=0.4, alpha=0.5)
    a1.grid(True, lw=0.4, alpha=0.5)
    verdict = "targets met" if res["met"] else "TARGETS UNMET"
    _title(fig, f"Modification design ({res['family']}, {res['samples']} samples): {verdict}",
           design, None)  # fmt: skip
    fig.subplots_adjust(top=0.85)
    return _save(fig, path)
