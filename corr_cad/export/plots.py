"""Matplotlib figures (PNG). The only module importing matplotlib."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..design import GearDesign  # noqa: E402
from ..kinematics import centre_distance, unit_radial  # noqa: E402
from ..profile import ProfileCurve  # noqa: E402

__all__ = [
    "preview_png",
    "forces_png",
    "load_distribution_png",
    "interference_png",
    "clearance_png",
    "montecarlo_png",
    "sweep_png",
]


def _save(fig, path: Path) -> Path:
    path = Path(path)
    tmp = path.with_name(path.name + ".part")
    fig.savefig(tmp, dpi=130, format="png", metadata={"Software": None})
    plt.close(fig)
    tmp.replace(path)
    return path


def _circle(ax, centre, radius, **kw):
    a = np.linspace(0, 2 * np.pi, 721)
    ax.plot(centre[0] + radius * np.sin(a), centre[1] + radius * np.cos(a), **kw)


def preview_png(
    design: GearDesign,
    working: ProfileCurve,
    theoretical: ProfileCurve,
    path: Path,
    crank_angle_rad: float = 0.0,
) -> Path:
    """Second stage at one crank angle: gear, locus, cam, rollers, plus a tooth close-up."""
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 6))
    wp = working.sample(400)
    tp = theoretical.sample(400)
    e, Rj, r = design.eccentricity, design.cam_radius, design.roller_radius
    L = design.link_length
    for a in (ax, ax2):
        a.fill(np.r_[wp[:, 0], wp[:1, 0]], np.r_[wp[:, 1], wp[:1, 1]], color="#dde6f0", zorder=0)
        a.plot(
            np.r_[wp[:, 0], wp[:1, 0]],
            np.r_[wp[:, 1], wp[:1, 1]],
            color="C0",
            lw=1.2,
            label="working profile",
        )
        a.plot(
            np.r_[tp[:, 0], tp[:1, 0]],
            np.r_[tp[:, 1], tp[:1, 1]],
            "--",
            color="C7",
            lw=0.8,
            label="theoretical profile (roller centres)",
        )
        _circle(a, (0, 0), design.ring_outer_radius, color="k", lw=1.0)
        # crank_angle_rad is relative to the frame (= z * frame angle).
        theta0 = crank_angle_rad / design.tooth_count
        phi_abs = crank_angle_rad + theta0
        cam_c = e * unit_radial(phi_abs)
        _circle(a, cam_c, Rj, color="C3", lw=1.0, label="disk cam")
        theta = theta0 + np.arange(design.roller_count) * design.slot_pitch_rad
        s = centre_distance(phi_abs - theta, e, L)
        centres = s[:, None] * unit_radial(theta)
        for c in centres:
            _circle(a, c, r, color="C2", lw=0.8)
        a.set_aspect("equal")
        a.set_xlabel("x [mm]")
        a.set_ylabel("y [mm]")
    ax.set_title(f"z = {design.tooth_count}, e = {e:g}, Rj = {Rj:g}, r = {r:g} mm")
    ax.legend(loc="lower left", fontsize=7)
    # Close-up around the tooth space on +y and its neighbours.
    span = 2.5 * (2 * np.pi / design.tooth_count)
    top = L + e + r
    ax2.set_xlim(-top * np.sin(span / 2), top * np.sin(span / 2))
    ax2.set_ylim(top - 4 * r - 2 * e, design.ring_outer_radius + 2)
    ax2.set_title("tooth close-up (tooth space on +y)")
    return _save(fig, path)


def forces_png(angles_deg: np.ndarray, F_j, F_s, F_n, path: Path, title: str = "") -> Path:
    """Forces on roller 1 against crank angle (paper Figs. 11-16 style)."""
    fig, ax = plt.subplots(figsize=(8, 4.5))
    ax.plot(angles_deg, F_j, label="$F_j$ (cam)")
    ax.plot(angles_deg, F_n, label="$F_n$ (inner gear)")
    ax.plot(angles_deg, F_s, label="$F_s$ (slot wall)")
    ax.set_xlabel("crank angle relative to the frame [deg]")
    ax.set_ylabel("force on roller 1 [N]")
    ax.set_xlim(float(angles_deg.min()), float(angles_deg.max()))
    ax.grid(alpha=0.3)
    ax.legend()
    ax.set_title(title or "mesh forces on roller 1")
    return _save(fig, path)


def load_distribution_png(
    design: GearDesign, crank_angle_deg: float, F_n: np.ndarray, path: Path
) -> Path:
    """Polar picture of the gear force on every roller at one crank angle."""
    fig = plt.figure(figsize=(6, 6))
    ax = fig.add_subplot(projection="polar")
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)  # angles from +y towards +x, as in the paper
    theta = np.arange(design.roller_count) * design.slot_pitch_rad
    ax.bar(theta, F_n, width=0.6 * design.slot_pitch_rad, color="C1", alpha=0.8)
    ax.set_title(f"gear force $F_n$ per roller [N], crank at {crank_angle_deg:g} deg")
    return _save(fig, path)


def interference_png(angles_deg, rows, parts, allowance, path: Path) -> Path:
    """Worst intersection volume and largest gap per crank angle, with the allowances."""
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for i, p in enumerate(parts):
        vol = [max(r[f"{p}_volume"] for r in rows if r["crank_angle_deg"] == a) for a in angles_deg]
        gap = [max(r[f"{p}_gap"] for r in rows if r["crank_angle_deg"] == a) for a in angles_deg]
        ax1.plot(angles_deg, vol, "o-", ms=3, color=f"C{i}", label=f"roller vs {p}")
        ax1.axhline(allowance[p]["volume_mm3"], color=f"C{i}", ls=":", lw=0.8)
        ax2.plot(angles_deg, gap, "o-", ms=3, color=f"C{i}", label=f"roller vs {p}")
    ax2.axhline(
        allowance["ring"]["gap_mm"], color="k", ls=":", lw=0.8, label="tessellation allowance"
    )
    ax1.set_ylabel("worst intersection volume [mm$^3$]")
    ax1.set_yscale("symlog", linthresh=1e-6)
    ax1.set_ylim(bottom=0.0)
    ax2.set_ylabel("largest min. gap [mm]")
    ax2.set_xlabel("crank angle relative to the frame [deg]")
    ax1.legend(fontsize=8)
    ax2.legend(fontsize=8)
    ax1.set_title("interference check (dotted: what tessellation alone can produce)")
    return _save(fig, path)


def _envelope(ang, values, bins: int = 720):
    """Smallest and largest over rollers and over each of ``bins`` angle bins (exact envelope)."""
    lo, hi = values.min(axis=1), values.max(axis=1)
    n = len(ang)
    if n <= bins:
        return ang, lo, hi
    edges = np.linspace(0, n, bins + 1).astype(int)
    starts = edges[:-1]
    return ang[starts], np.minimum.reduceat(lo, starts), np.maximum.reduceat(hi, starts)


def clearance_png(clr, path: Path) -> Path:
    """Exact clearances over the cycle: smallest and largest over the rollers, um.

    Values within 1e-9 mm of zero (the closed forms' round-off) are drawn as 0.
    """
    ang = np.degrees(clr.crank_angles)
    order = np.argsort(ang)
    ang = ang[order]
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True)
    span = 1.0
    for i, name in enumerate(("cam", "ring", "slot")):
        a = getattr(clr, name)[order]
        a = np.where(np.abs(a) < 1e-9, 0.0, a) * 1e3
        x, lo, hi = _envelope(ang, a)
        span = max(span, float(np.abs(lo).max()), float(np.abs(hi).max()))
        ax1.fill_between(x, lo, hi, color=f"C{i}", alpha=0.15, lw=0)
        ax1.plot(x, lo, color=f"C{i}", lw=1.2, label=f"roller vs {name}: smallest")
    ax1.axhline(0.0, color="k", lw=0.8)
    ax1.set_ylim(-1.1 * span, 1.1 * span)
    ax1.set_ylabel("clearance [um] (negative: interference)")
    ax1.set_title("exact clearance over the cycle (band: all rollers)")
    ax1.legend(fontsize=8)
    x, lo, hi = _envelope(ang, clr.neighbour[order])
    ax2.plot(x, lo, color="C3", lw=1.2, label="roller vs neighbours: smallest")
    ax2.plot(x, hi, color="C3", lw=0.8, ls="--", label="largest")
    ax2.set_ylabel("clearance [mm]")
    ax2.set_xlabel("crank angle relative to the frame [deg]")
    ax2.legend(fontsize=8)
    return _save(fig, path)


_LIMIT_OF = {
    "peak_pressure": "max_contact_pressure",
    "peak_gear_force": "max_gear_force",
    "min_loaded_rollers": "min_loaded_rollers",
    "lost_motion_arcmin": "max_lost_motion_arcmin",
}
_LABEL = {
    "peak_pressure": "peak contact pressure [MPa]",
    "peak_gear_force": "peak gear force $F_n$ [N]",
    "min_loaded_rollers": "fewest loaded rollers",
    "lost_motion_arcmin": "output lost motion [arcmin]",
}


def montecarlo_png(metrics: dict, checks, path: Path) -> Path:
    """Histograms of the per-sample metrics with the check limits."""
    fig, axes = plt.subplots(2, 2, figsize=(10, 7))
    for ax, (name, values) in zip(axes.ravel(), metrics.items(), strict=False):
        ax.hist(values, bins=40, color="C0", alpha=0.8)
        limit = getattr(checks, _LIMIT_OF[name])
        if limit is not None:
            ax.axvline(limit, color="C3", lw=1.5, label="limit")
            ax.legend(fontsize=8)
        ax.set_xlabel(_LABEL[name])
        ax.set_ylabel("samples")
    fig.suptitle(f"Monte Carlo, {len(next(iter(metrics.values())))} samples")
    fig.tight_layout()
    return _save(fig, path)


def sweep_png(name: str, points: list[dict], path: Path) -> Path:
    """Means and peaks of roller 1's forces against the swept value (Figs. 11-16 style)."""
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    ok = [p for p in points if p["status"] == "ok"]
    x = [p["value"] for p in ok]
    for key, label in (("F_j_mean", "$F_j$"), ("F_n_mean", "$F_n$"), ("F_s_mean", "$F_s$")):
        ax1.plot(x, [p[key] for p in ok], "o-", label=f"mean {label}")
    for key, label in (
        ("F_j_peak", "peak $F_j$"),
        ("F_n_peak", "peak $F_n$"),
        ("F_s_peak_to_peak", "p-p $F_s$"),
    ):
        ax2.plot(x, [p[key] for p in ok], "o-", label=label)
    skipped = [p["value"] for p in points if p["status"] != "ok"]
    for ax in (ax1, ax2):
        for v in skipped:
            ax.axvline(v, color="0.7", ls=":", lw=1)
        ax.set_xlabel(name.replace("_", " ") + " [mm]")
        ax.set_ylabel("force on roller 1 [N]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    title = name.replace("_", " ")
    if skipped:
        title += f" (dotted: {len(skipped)} points not computed - undercut or invalid)"
    fig.suptitle(title)
    fig.tight_layout()
    return _save(fig, path)
