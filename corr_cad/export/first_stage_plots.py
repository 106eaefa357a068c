"""``first_stage.png``: the first gear stage at one crank angle, and its two meshes.

The pinion, the three wheels and the internal crank gear drawn from the same
outlines as their DXF files (:func:`~corr_cad.geometry.gear_outline.approximate_gear`),
each placed as in ``assembly_<angle>deg.*``
(:func:`~corr_cad.geometry.first_stage_parts.first_stage_placements`), so the
picture shows the teeth in mesh as the shop's parts will be.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.patches import PathPatch

from corr_cad.export.plots import _circle, _ring_path, _save, _xy_circle, plt
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.first_stage import FirstStageGeometry
from corr_cad.geometry.first_stage_parts import first_stage_layout, first_stage_placements
from corr_cad.geometry.kinematics import rotate_by_polar_angle

__all__ = ["placed_gear_outlines", "first_stage_png"]

#: Colours of the shaded material: crank gear, wheels, pinion.
_FILL = {"crank_gear": "#c9d7e8", "wheel": "#f2d0cb", "pinion": "#b9e0b5"}
_EDGE = {"crank_gear": "C0", "wheel": "C3", "pinion": "C2"}


def placed_gear_outlines(
    design: GearDesign, fs: FirstStageGeometry, outlines: dict, crank_angle_rad: float = 0.0
) -> dict[str, np.ndarray]:
    """``{instance name: (n, 2) outline}`` of the pinion, the wheels and the crank gear,
    placed as in the assembly at ``crank_angle_rad`` (relative to the frame), mm.

    ``outlines`` maps ``pinion``, ``wheel`` and ``crank_gear`` to their
    outlines in part coordinates ((n, 2) vertices).
    """
    out = {}
    for p in first_stage_placements(design, fs, crank_angle_rad):
        if p.part in outlines:
            pts = np.asarray(outlines[p.part], dtype=float) + np.asarray(p.pre_offset, float)
            out[p.name] = rotate_by_polar_angle(pts, p.angle_rad) + np.asarray(p.offset[:2])
    return out


def first_stage_png(
    design: GearDesign,
    fs: FirstStageGeometry,
    outlines: dict,
    path: Path,
    crank_angle_rad: float = 0.0,
) -> Path:
    """The whole first stage (left) and close-ups of wheel 1's two meshes (right).

    Shaded: each gear's material (the crank gear from its rim to its teeth,
    the pinion and the wheels less their bores). Dotted: the working pitch
    circles, which roll on each other.
    """
    lay = first_stage_layout(design, fs)
    placed = placed_gear_outlines(design, fs, outlines, crank_angle_rad)
    a = fs.centre_distance
    zp, zw, zc = fs.pinion.teeth, fs.wheel.teeth, fs.crank_gear.teeth
    # working pitch radii: the pinion's and the wheel's on a, the wheel's and
    # the crank gear's on the same a of the internal mesh
    r_p, r_w1 = a * zp / (zp + zw), a * zw / (zp + zw)
    r_w2, r_c = a * zw / (zc - zw), a * zc / (zc - zw)
    centres = {
        name: np.asarray(p.offset[:2])
        for p in first_stage_placements(design, fs, crank_angle_rad)
        if (name := p.name) in placed
    }

    fig = plt.figure(figsize=(13, 7.4))
    ax = fig.add_axes((0.05, 0.13, 0.5, 0.72))
    ax_pw = fig.add_axes((0.62, 0.52, 0.34, 0.33))
    ax_wc = fig.add_axes((0.62, 0.13, 0.34, 0.33))
    for axis in (ax, ax_pw, ax_wc):
        for name, pts in placed.items():
            part = name.split("_")[0] if name.startswith("wheel") else name
            if part == "crank_gear":
                patch = _ring_path(_xy_circle(centres[name], lay.rim_outer), pts)
            else:
                bore = lay.pinion_bore if part == "pinion" else lay.wheel_bore
                patch = _ring_path(pts, _xy_circle(centres[name], bore))
            axis.add_artist(PathPatch(patch, facecolor=_FILL[part], edgecolor="none", zorder=0))
            label = {"crank_gear": "crank gear (internal)", "wheel_1": "wheels (3)"}.get(name)
            label = "pinion (input)" if name == "pinion" else label
            axis.plot(*np.vstack([pts, pts[:1]]).T, color=_EDGE[part], lw=0.8, label=label)
        _circle(axis, (0, 0), lay.rim_outer, color="C0", lw=0.8)
        _circle(axis, (0, 0), lay.pinion_bore, color="C2", lw=0.6)
        for k in (1, 2, 3):
            c = centres[f"wheel_{k}"]
            _circle(axis, c, lay.wheel_bore, color="C3", lw=0.6)
            _circle(axis, c, lay.wheel_bearing_inner, color="C7", lw=0.6, ls="--",
                    label="wheel bearings (bore)" if k == 1 else None)  # fmt: skip
            for r in (r_w1, r_w2):
                _circle(axis, c, r, color="C7", lw=0.5, ls=":")
            axis.plot(*c, "k+", ms=6)
        _circle(axis, (0, 0), r_p, color="C7", lw=0.5, ls=":", label="working pitch circles")
        _circle(axis, (0, 0), r_c, color="C7", lw=0.5, ls=":")
        axis.plot([0], [0], "k+", ms=8)
        axis.set_aspect("equal")
        axis.set_xlabel("x [mm]")
        axis.set_ylabel("y [mm]")
    top = lay.rim_outer * 1.12
    ax.set_xlim(-top, top)
    ax.set_ylim(-top, top)
    ax.set_title(f"crank angle {np.degrees(crank_angle_rad):g} deg (relative to the frame)",
                 fontsize=10)  # fmt: skip
    for k in (1, 2, 3):
        c = centres[f"wheel_{k}"]
        u = c / np.linalg.norm(c)
        leader = {"arrowstyle": "-", "color": "C3", "lw": 0.6}
        ax.annotate(f"wheel {k}", c, xytext=c + u * 0.35 * a, fontsize=8, ha="center",
                    va="center", arrowprops=leader)  # fmt: skip
    # The close-ups: each mesh seen along wheel 1's line of centres (+y).
    m = fs.stage.module
    u1 = centres["wheel_1"] / np.linalg.norm(centres["wheel_1"])
    for axis, y, mesh, k in ((ax_pw, r_p, "pinion - wheel 1", 0),
                             (ax_wc, a + r_w2, "wheel 1 - crank gear", 1)):  # fmt: skip
        c = y * u1
        axis.set_xlim(c[0] - 5 * m, c[0] + 5 * m)
        axis.set_ylim(c[1] - 2.5 * m, c[1] + 2.5 * m)
        axis.set_title(
            f"{mesh}: working pressure angle {fs.working_pressure_angle_deg[k]:.4g} deg, "
            f"backlash {1000 * fs.backlash[k]:.3g} um",
            fontsize=9,
        )
    handles, labels = ax.get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=5, fontsize=8, frameon=False)
    fig.suptitle(
        "First stage (shaded: gear material)\n"
        f"pinion / wheels / crank gear {zp} / {zw} / {zc} teeth, module {m:g} mm, "
        f"i1 = {fs.ratio:g}, centre distance {a:.4g} mm",
        fontsize=11,
    )
    return _save(fig, path)
