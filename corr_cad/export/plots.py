"""Matplotlib figures (PNG): preview, forces, load distribution, interference, clearance.

Sets matplotlib's Agg backend; :mod:`corr_cad.export.plots_tolerance` and the
inspection chart (:mod:`corr_cad.export.inspection_io`) draw through it (its
``_save`` and ``_title``). Every figure states the design (z, Rj, r, e, l), the load and the
units, so a picture taken out of its folder still says what it shows. Figures
are byte-deterministic (no time stamps, no software tag).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.layout_engine import PlaceHolderLayoutEngine  # noqa: E402
from matplotlib.patches import PathPatch, Polygon  # noqa: E402
from matplotlib.path import Path as MplPath  # noqa: E402

from corr_cad.export.files import writing  # noqa: E402
from corr_cad.figure_text import figure  # noqa: E402
from corr_cad.geometry.design import GearDesign  # noqa: E402
from corr_cad.geometry.kinematics import centre_distance, unit_radial  # noqa: E402
from corr_cad.geometry.profile import ProfileCurve  # noqa: E402

__all__ = [
    "design_caption",
    "preview_png",
    "forces_png",
    "load_distribution_png",
    "interference_png",
    "clearance_png",
]


def _save(fig, path: Path) -> Path:
    path = Path(path)
    if isinstance(fig.get_layout_engine(), PlaceHolderLayoutEngine):
        # Left by tight_layout: savefig would draw the figure once more, without
        # rendering, before drawing it (0.1-0.3 s a figure), for a layout already done.
        fig.set_layout_engine(None)
    try:
        with writing(path) as tmp:
            fig.savefig(tmp, dpi=130, format="png", metadata={"Software": None})
    finally:
        plt.close(fig)
    return path


def design_caption(design: GearDesign | None, input_torque: float | None = None) -> str:
    """One line naming the design and the load, e.g. for a figure's subtitle.

    >>> design_caption(GearDesign(), 1.1e5)
    'z = 25, Rj = 135 mm, r = 8 mm, e = 3.5 mm, l = 12 mm; M0 = 110,000 N*mm'
    """
    if design is None:
        return ""
    text = (
        f"z = {design.tooth_count}, Rj = {design.cam_radius:g} mm, "
        f"r = {design.roller_radius:g} mm, e = {design.eccentricity:g} mm, "
        f"l = {design.roller_length:g} mm"
    )
    if input_torque is not None:
        text += f"; M0 = {figure(input_torque, 3)} N*mm"
    return text


def _title(fig, title: str, design: GearDesign | None, input_torque: float | None) -> None:
    cap = design_caption(design, input_torque)
    fig.suptitle(title + (f"\n{cap}" if cap else ""), fontsize=11)


def _xy_circle(centre, radius, n=721):
    a = np.linspace(0, 2 * np.pi, n)
    return np.column_stack([centre[0] + radius * np.sin(a), centre[1] + radius * np.cos(a)])


def _circle(ax, centre, radius, **kw):
    p = _xy_circle(centre, radius)
    ax.plot(p[:, 0], p[:, 1], **kw)


def _ring_path(outer: np.ndarray, inner: np.ndarray) -> MplPath:
    """Region between two closed curves (the inner one a hole)."""

    def closed(p, reverse):
        p = p[::-1] if reverse else p
        return np.vstack([p, p[:1]])

    def area(p):
        return 0.5 * float(
            np.dot(p[:, 0], np.roll(p[:, 1], -1)) - np.dot(p[:, 1], np.roll(p[:, 0], -1))
        )

    o = closed(outer, area(outer) < 0)  # counter-clockwise
    i = closed(inner, area(inner) > 0)  # clockwise
    verts = np.vstack([o, i])
    codes = np.r_[
        MplPath.MOVETO,
        [MplPath.LINETO] * (len(o) - 2),
        MplPath.CLOSEPOLY,
        MplPath.MOVETO,
        [MplPath.LINETO] * (len(i) - 2),
        MplPath.CLOSEPOLY,
    ]
    return MplPath(verts, codes)


def preview_png(
    design: GearDesign,
    working: ProfileCurve,
    theoretical: ProfileCurve,
    path: Path,
    crank_angle_rad: float = 0.0,
    modification: str = "",
) -> Path:
    """Second stage at one crank angle: ring, cam, rollers and frame, plus a tooth close-up.

    Shaded: the gear ring's material (outer rim to working profile) and the
    cam (minus its bore). The slotted frame plate, which lies in its own
    plane beside the gear and cam, is drawn in outline. ``modification``: the
    families and amounts of a modified ring
    (:func:`corr_cad.geometry.modification.amounts_text`), named in the
    profile's legend entry and the title. Roller labels stand outside the
    ring, each with a leader to its roller.
    """
    from corr_cad.geometry.parts import slot_polygon

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(13, 7.4))
    profile_label = (
        f"working profile (gear, modified: {modification})"
        if modification
        else "working profile (gear)"
    )
    wp = working.sample(max(400, 40 * design.tooth_count))
    tp = theoretical.sample(max(400, 40 * design.tooth_count))
    e, Rj, r = design.eccentricity, design.cam_radius, design.roller_radius
    L = design.link_length
    # crank_angle_rad is relative to the frame (= z * frame angle).
    theta0 = crank_angle_rad / design.tooth_count
    phi_abs = crank_angle_rad + theta0
    cam_c = e * unit_radial(phi_abs)
    theta = theta0 + np.arange(design.roller_count) * design.slot_pitch_rad
    s = centre_distance(phi_abs - theta, e, L)
    centres = s[:, None] * unit_radial(theta)
    ring = _ring_path(_xy_circle((0, 0), design.ring_outer_radius), wp)
    cam = _ring_path(_xy_circle(cam_c, Rj), _xy_circle((0, 0), design.cam_bore_radius))
    for a in (ax, ax2):
        # add_artist, not add_patch or fill: the limits are set below, and
        # add_patch's data-limit update walks every segment of these dense
        # paths as a Bezier curve (0.5 s of this figure). Same pixels.
        a.add_artist(PathPatch(ring, facecolor="#c9d7e8", edgecolor="none", zorder=0))
        a.add_artist(PathPatch(cam, facecolor="#f2d0cb", edgecolor="none", zorder=0))
        a.plot(*np.vstack([wp, wp[:1]]).T, color="C0", lw=1.2, label=profile_label)
        a.plot(
            *np.vstack([tp, tp[:1]]).T,
            "--",
            color="C7",
            lw=0.8,
            label="theoretical profile (roller centres)",
        )
        _circle(a, (0, 0), design.ring_outer_radius, color="C0", lw=1.0)
        _circle(a, cam_c, Rj, color="C3", lw=1.0, label="disk cam")
        _circle(a, (0, 0), design.cam_bore_radius, color="C3", lw=0.6)
        for k, th in enumerate(theta):
            sp = slot_polygon(design, th, 0.002 * r)
            a.plot(
                *np.vstack([sp, sp[:1]]).T,
                color="C4",
                lw=0.6,
                label="frame slots (frame plane)" if k == 0 else None,
            )
        for k, c in enumerate((design.frame_inner_radius, design.frame_outer_radius)):
            _circle(a, (0, 0), c, color="C4", lw=0.6, ls="-.",
                    label="frame plate rims (frame plane)" if k == 0 else None)  # fmt: skip
        for k, c in enumerate(centres):
            roller = _xy_circle(c, r, 181)
            a.add_artist(Polygon(roller, closed=True, color="#b9e0b5", zorder=1))
            a.plot(*roller.T, color="C2", lw=0.8, label="rollers" if k == 0 else None)
        a.plot([0, cam_c[0]], [0, cam_c[1]], color="C3", lw=1.5)
        a.plot([0], [0], "k+", ms=8)
        a.set_aspect("equal")
        a.set_xlabel("x [mm]")
        a.set_ylabel("y [mm]")
    outer = max(design.frame_outer_radius, design.ring_outer_radius)
    top = outer * 1.2  # room for the roller labels outside the ring
    ax.set_xlim(-top, top)
    ax.set_ylim(-top, top)
    ax.set_title(
        f"crank angle {np.degrees(crank_angle_rad):g} deg (relative to the frame)", fontsize=10
    )
    for k in (0, 1):  # outside the ring, one slot pitch apart, a leader to each roller
        u = centres[k] / np.linalg.norm(centres[k])
        ax.annotate(
            f"roller {k + 1}",
            centres[k],
            xytext=u * outer * 1.1,
            fontsize=8,
            ha="center",
            va="center",
            arrowprops={"arrowstyle": "-", "color": "C2", "lw": 0.6},
        )
    # Close-up around the tooth space on +y and its neighbours.
    span = 2.5 * (2 * np.pi / design.tooth_count)
    top2 = L + e + r
    ax2.set_xlim(-top2 * np.sin(span / 2), top2 * np.sin(span / 2))
    ax2.set_ylim(top2 - 4 * r - 2 * e, design.ring_outer_radius + 2)
    ax2.set_title("tooth close-up (tooth space on +y)", fontsize=10)
    handles, labels = ax.get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=8, frameon=False)
    title = "Second stage (shaded: gear ring and cam material)"
    if modification:
        title += f"; modified ring: {modification}"
    _title(fig, title, design, None)
    fig.subplots_adjust(left=0.06, right=0.98, top=0.88, bottom=0.14, wspace=0.25)
    return _save(fig, path)


_CONTACTS = (("p_cam", "cam", "C0"), ("p_gear", "inner gear", "C1"), ("p_slot", "slot wall", "C2"))


def forces_png(
    res,
    path: Path,
    design: GearDesign | None = None,
    input_torque: float | None = None,
    row: str = "",
) -> Path:
    """Forces over the crank cycle: the envelope over all rollers and roller 1,
    and the peak contact pressure of each contact (cam, gear, slot).

    ``row``: which row of the drive is drawn, said in the title ("" for the paper's row)."""
    ang = np.degrees(np.asarray(res.crank_angles))
    order = np.argsort(ang)
    ang = ang[order]
    F_j, F_n, F_s = (np.asarray(x)[order] for x in (res.F_j, res.F_n, res.F_s))
    style = dict(marker="o", ms=3) if len(ang) < 60 else {}
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 7.5), sharex=True)
    for F, name, c in (
        (F_j, "$F_j$ (cam)", "C0"),
        (F_n, "$F_n$ (inner gear)", "C1"),
        (np.abs(F_s), "$|F_s|$ (slot wall)", "C2"),
    ):
        ax1.plot(ang, F.max(axis=1), color=c, lw=1.6, label=f"max {name} over all rollers", **style)
        ax1.plot(ang, F[:, 0], color=c, lw=0.9, ls="--", label=f"{name}, roller 1", **style)
    k = np.unravel_index(np.argmax(F_n), F_n.shape)
    ax1.annotate(
        f"peak $F_n$ {F_n[k]:.0f} N\nroller {k[1] + 1} at {ang[k[0]]:g} deg",
        (ang[k[0]], F_n[k]),
        xytext=(10, -25),
        textcoords="offset points",
        fontsize=8,
        arrowprops=dict(arrowstyle="->", lw=0.6),
    )
    ax1.set_ylabel("force [N]")
    ax1.grid(alpha=0.3)
    ax1.legend(fontsize=7, ncol=3, loc="upper left", bbox_to_anchor=(0, -0.02, 1, 0), mode="expand")
    for key, name, c in _CONTACTS:
        p = np.asarray(getattr(res, key))[order]
        ax2.plot(ang, p.max(axis=1), color=c, lw=1.4, label=f"{name}: max over rollers", **style)
    P = np.maximum(np.maximum(res.p_cam, res.p_gear), res.p_slot)
    ax2.set_title(f"peak Hertz contact pressure, highest {P.max():.0f} MPa", fontsize=9)
    ax2.set_ylabel("contact pressure [MPa]")
    ax2.set_xlabel("crank angle relative to the frame [deg]")
    ax2.grid(alpha=0.3)
    ax2.legend(fontsize=8)
    if float(ang.max()) > float(ang.min()):  # [0, 0] or one angle: matplotlib's own margins
        ax2.set_xlim(float(ang.min()), float(ang.max()))
    ax1.set_ylim(bottom=0)
    ax2.set_ylim(bottom=0)
    title = "Mesh forces over the cycle (solid: envelope over all rollers)"
    _title(fig, f"{title}\n{row}" if row else title, design, input_torque)
    fig.subplots_adjust(left=0.09, right=0.97, top=0.9, bottom=0.08, hspace=0.55)
    return _save(fig, path)


#: Smallest angle (rad) between the eccentric arrow and the radial scale's ray:
#: the scale's innermost label, near the centre, spans about this much.
_SCALE_CLEARANCE = np.radians(40.0)


def _scale_gap(pitch: float, ecc: float, F_j, F_n, F_s) -> float:
    """Angle (rad) of the gap between two rollers where the radial scale goes.

    The gap between rollers 1 and 2 when neither carries load and the
    eccentric is at least ``_SCALE_CLEARANCE`` away; otherwise the gap
    farthest from both the eccentric arrow and every loaded roller's bars
    (load above 2 % of the largest), the middle of the widest free sector.
    """
    load = np.maximum(np.maximum(np.asarray(F_j), np.asarray(F_n)), np.abs(np.asarray(F_s)))
    n = len(load)
    gaps = (np.arange(n) + 0.5) * pitch

    def apart(a, b):
        return np.abs(np.mod(a - b + np.pi, 2 * np.pi) - np.pi)

    if max(load[0], load[1 % n]) <= 0.0 and apart(gaps[0], ecc) >= _SCALE_CLEARANCE:
        return float(gaps[0])
    busy = np.r_[np.flatnonzero(load > 0.02 * max(float(load.max()), 1e-300)) * pitch, ecc]
    room = apart(gaps[:, None], busy[None, :]).min(axis=1)
    return float(gaps[int(np.argmax(room))])


def load_distribution_png(
    design: GearDesign,
    crank_angle_deg: float,
    F_j: np.ndarray,
    F_n: np.ndarray,
    F_s: np.ndarray,
    path: Path,
    input_torque: float | None = None,
    note: str = "",
) -> Path:
    """Polar picture of the three forces on every roller at one crank angle.

    Frame coordinates: roller k sits at slot angle (k - 1) * 360/(z + 1)
    deg from +y towards +x, the eccentric at the crank angle.
    """
    fig = plt.figure(figsize=(7.5, 8))
    ax = fig.add_axes([0.1, 0.1, 0.8, 0.72], projection="polar")
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)  # angles from +y towards +x, as in the paper
    pitch = design.slot_pitch_rad
    theta = np.arange(design.roller_count) * pitch
    w = 0.22 * pitch
    for off, F, name, c in (
        (-w, F_j, "$F_j$ (cam)", "C0"),
        (0.0, F_n, "$F_n$ (inner gear)", "C1"),
        (w, np.abs(F_s), "$|F_s|$ (slot wall)", "C2"),
    ):
        ax.bar(theta + off, F, width=w, color=c, alpha=0.85, label=name)
    fmax = float(max(np.max(F_j), np.max(F_n), np.max(np.abs(F_s)), 1e-300))
    top = 1.18 * fmax
    ax.set_ylim(0, top)
    # Radial scale on a white ground, in a gap between two rollers, clear of the
    # eccentric arrow and of the loaded rollers' bars (rollers 1 and 2 when free).
    ecc = np.radians(crank_angle_deg)
    ax.set_rlabel_position(np.degrees(_scale_gap(pitch, ecc, F_j, F_n, F_s)))
    for t in ax.get_yticklabels():
        t.set_fontsize(7)
        t.set_bbox(dict(facecolor="white", edgecolor="none", alpha=0.8, pad=0.5))
    ax.set_xticks(theta)
    step = 1 if design.roller_count <= 40 else int(np.ceil(design.roller_count / 40))
    ax.set_xticklabels(
        [str(k + 1) if k % step == 0 else "" for k in range(design.roller_count)], fontsize=7
    )
    ax.annotate(
        "",
        xy=(ecc, 0.95 * top),
        xytext=(ecc, 0.0),
        arrowprops=dict(arrowstyle="-|>", color="C3", lw=1.8),
    )
    # The label runs along the arrow's shaft, inside the rim: clear of the roller
    # numbers outside it, and of the radial scale (another gap, see _scale_gap).
    rot = 90.0 - np.degrees(ecc)
    flip = np.mod(rot + 90.0, 360.0) > 180.0  # pointing left: turn the text upright
    normal = np.radians(rot + 90.0)
    ax.annotate(
        "eccentric",
        xy=(ecc, 0.62 * top),
        xytext=(7.0 * np.cos(normal), 7.0 * np.sin(normal)),
        textcoords="offset points",
        rotation=rot + (180.0 if flip else 0.0),
        rotation_mode="anchor",
        color="C3",
        fontsize=8,
        ha="center",
        va="center",
    )
    loaded = int(np.count_nonzero(F_j > 0))
    ax.set_title(
        f"roller numbers around the rim; radial scale in N; {loaded} of "
        f"{design.roller_count} rollers loaded",
        fontsize=8,
        pad=18,
    )
    fig.legend(loc="lower center", ncol=3, fontsize=8, frameon=False)
    _title(
        fig,
        f"Forces on every roller at crank angle {crank_angle_deg:.4g} deg{note} [N]",
        design,
        input_torque,
    )
    return _save(fig, path)


def interference_png(
    angles_deg,
    rows,
    parts,
    allowance,
    path: Path,
    design: GearDesign | None = None,
    ok: bool | None = None,
) -> Path:
    """Worst intersection volume and largest gap per crank angle, with the allowances."""
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 7.5), sharex=True)
    bad = 0
    for i, p in enumerate(parts):
        vol = [max(r[f"{p}_volume"] for r in rows if r["crank_angle_deg"] == a) for a in angles_deg]
        gap = [max(r[f"{p}_gap"] for r in rows if r["crank_angle_deg"] == a) for a in angles_deg]
        bad += sum(v > allowance[p]["volume_mm3"] for v in vol)
        bad += sum(g > allowance[p]["gap_mm"] for g in gap)
        ax1.plot(angles_deg, vol, "o-", ms=3, color=f"C{i}", label=f"roller vs {p}")
        ax1.axhline(
            allowance[p]["volume_mm3"],
            color=f"C{i}",
            ls=":",
            lw=1.0,
            label=f"allowance {p}: {allowance[p]['volume_mm3']:.2g} mm$^3$",
        )
        ax2.plot(angles_deg, gap, "o-", ms=3, color=f"C{i}", label=f"roller vs {p}")
    ax2.axhline(
        allowance["ring"]["gap_mm"],
        color="k",
        ls=":",
        lw=1.0,
        label=f"allowance: {allowance['ring']['gap_mm']:.2g} mm",
    )
    ax1.set_ylabel("worst intersection volume [mm$^3$]")
    ax1.set_yscale("symlog", linthresh=1e-6)
    ax1.set_ylim(bottom=0.0)
    ax2.set_ylabel("largest min. gap [mm]")
    ax2.set_xlabel("crank angle relative to the frame [deg]")
    for a in (ax1, ax2):
        a.grid(alpha=0.3)
        a.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    passed = (bad == 0) if ok is None else ok
    verdict = (
        "PASS: no interference beyond tessellation"
        if passed
        else "FAIL: interference beyond the tessellation allowance"
    )
    ax1.set_title(verdict, color="C2" if passed else "C3", fontsize=10, fontweight="bold")
    fig.text(
        0.02,
        0.01,
        "Allowance (dotted): what tessellation alone can produce at a tangent contact - both "
        "meshes may miss the exact\nsurface by the chord tolerance, a lens of penetration "
        "2 x chord tolerance, or a gap of the same size. Within it counts as contact.",
        fontsize=7,
    )
    _title(fig, f"Interference check over {len(angles_deg)} crank positions", design, None)
    fig.subplots_adjust(left=0.1, right=0.73, top=0.88, bottom=0.14, hspace=0.25)
    return _save(fig, path)


def clearance_png(
    clr,
    path: Path,
    design: GearDesign | None = None,
    rows: dict | None = None,
    summary: dict | None = None,
    note: str = "",
) -> Path:
    """``clearance.png``: :func:`corr_cad.export.plots_clearance.clearance_figure` (one row,
    or the drive's ``rows``; ``summary`` names the extremes' rollers, ``note`` a line under
    the title), with the design line."""
    from corr_cad.export.plots_clearance import clearance_figure

    fig, title = clearance_figure(clr, rows, summary, note)
    _title(fig, title, design, None)
    return _save(fig, path)
