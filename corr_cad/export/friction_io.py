"""Files of the efficiency map, the rated life and the hysteresis loop: efficiency.csv,
efficiency.png, life.csv, hysteresis.csv.

``efficiency.csv``: one row per input speed and output torque, both
directions' efficiencies (a backdriving efficiency of 0 with
``self_locking_backdriving`` true: self-locking); the forward powers in W at
that speed for the whole drive, each computed on its own from the forces:
the input from the crank moment, each loss from its contact's friction
force and slip, the output from the rollers' moment on the frame
(Coulomb losses scale with the speed, so the efficiency does not).
``life.csv``: one row per component, L10 in hours at T_R and at the rated
torque from life, both at the rated output speed. ``hysteresis.csv``: the
loop at the position of the widest loop at +-T_R, one row per torque level
of the datasheet (-T_R .. -0, +0 .. +T_R), the frictionless windup and both
branches.
"""

from __future__ import annotations

import math
from pathlib import Path

from corr_cad.export.files import write_csv
from corr_cad.mechanics.losses.efficiency import FrictionFigures

__all__ = [
    "EFFICIENCY_COLUMNS",
    "LIFE_COLUMNS",
    "HYSTERESIS_COLUMNS",
    "write_friction_files",
    "write_hysteresis_csv",
    "efficiency_figure",
    "efficiency_png",
]

EFFICIENCY_COLUMNS = (
    "input_speed_rpm",
    "output_torque_Nm",
    "torque_share",
    "efficiency_forward",
    "efficiency_backdriving",
    "input_power_W",
    "loss_cam_W",
    "loss_slot_W",
    "loss_ring_W",
    "loss_bearing_W",
    "output_power_W",
    "self_locking_backdriving",
)
LIFE_COLUMNS = ("component", "method", "life_h", "life_h_at_rated_torque_from_life")
HYSTERESIS_COLUMNS = (
    "output_angle_deg",
    "output_torque_Nm",
    "windup_frictionless_arcmin",
    "windup_rising_arcmin",
    "windup_falling_arcmin",
)
#: arcmin per rad.
_ARCMIN = 60.0 * 180.0 / math.pi

_METHOD = {
    "bearing": "ISO 281 basic rating life, equivalent load exponent 10/3",
    "cam": "Lundberg-Palmgren line contact, cam as inner raceway",
    "ring": "Lundberg-Palmgren line contact, ring as outer raceway",
    "system": "Weibull combination, slope 9/8",
}


def _g(v: float) -> str:
    return "inf" if not math.isfinite(v) else f"{v:.9g}"


def write_friction_files(ff: FrictionFigures, out: Path) -> list[str]:
    """Write ``efficiency.csv`` (and ``life.csv`` with lives); returns the names written."""
    out = Path(out)
    T_R = ff.rated_torque / 1000.0
    rows = []
    for n in ff.speeds_rpm:
        # Output speed in rad/s; powers are N*mm per rad of output: times it and 1e-3 is W.
        to_W = 2.0 * math.pi * n / 60.0 / ff.ratio * 1e-3
        for i, s in enumerate(ff.shares):
            # The map's powers are the modelled rows', which carry ``share`` of the torque:
            # one fixed factor (not fitted to the result), so that the balance
            # input - losses - output stays a check of the equilibrium.
            k = to_W / ff.share
            rows.append(
                [
                    f"{n:.9g}",
                    f"{s * T_R:.9g}",
                    f"{s:.9g}",
                    f"{ff.forward[i]:.12g}",
                    f"{ff.backdriving[i]:.12g}",
                    f"{ff.input_power[i] * k:.9g}",
                    *(f"{v * k:.9g}" for v in ff.losses_forward[i]),
                    f"{ff.output_power[i] * k:.9g}",
                    "true" if ff.backdriving[i] <= 0.0 else "false",
                ]
            )
    write_csv(out / "efficiency.csv", EFFICIENCY_COLUMNS, rows)
    names = ["efficiency.csv"]
    if ff.lives is not None:
        at = ff.lives_at_rated_from_life or {}
        life_rows = [
            [k, _METHOD[k.split("_")[0]], _g(v), _g(at.get(k, math.nan))]
            for k, v in ff.lives.items()
        ]
        write_csv(out / "life.csv", LIFE_COLUMNS, life_rows)
        names.append("life.csv")
    return names


def write_hysteresis_csv(loop: dict, out: Path) -> str:
    """Write ``hysteresis.csv`` from a loop
    (:func:`corr_cad.mechanics.losses.hysteresis.hysteresis_loop` at one position, rad and
    N*mm); returns its name."""
    angle = f"{math.degrees(loop['output_angle']):.9g}"
    rows = [
        [
            angle,
            f"{t / 1000.0:.9g}",
            *(f"{loop[k][i] * _ARCMIN:.12g}" for k in ("frictionless", "rising", "falling")),
        ]
        for i, t in enumerate(loop["torques"])
    ]
    write_csv(Path(out) / "hysteresis.csv", HYSTERESIS_COLUMNS, rows)
    return "hysteresis.csv"


def efficiency_figure(ff: FrictionFigures, note: str = ""):
    """The matplotlib figure of :func:`efficiency_png` (torques with thousands separators,
    efficiencies in plain percent, the title on lines that fit the figure)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter, ScalarFormatter

    from corr_cad.figure_text import figure

    T = ff.shares * ff.rated_torque / 1000.0
    fig, ax = plt.subplots(figsize=(7, 4.6))
    for k, n in enumerate(ff.speeds_rpm):
        ax.plot(T, 100 * ff.forward, marker="o", ms=4 + 2 * k, mfc="none", label=f"{n:g} rpm in")
    locked = " (0: self-locking)" if ff.self_locking_shares() else ""
    ax.plot(T, 100 * ff.backdriving, color="0.4", ls="--", label="backdriving" + locked)
    ax.set_xlabel("output torque [N*m]")
    ax.set_ylabel("efficiency [%]")
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _pos: figure(v)))
    plain = ScalarFormatter(useOffset=False)
    plain.set_scientific(False)
    ax.yaxis.set_major_formatter(plain)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fr = ff.friction
    ax.set_title(
        f"mu cam/slot/ring {fr.mu_cam:g}/{fr.mu_slot:g}/{fr.mu_ring:g}, bearing "
        f"{fr.mu_bearing:g} ({fr.mounting} cam)\nCoulomb: the same at every speed"
        + (f"\n{note}" if note else ""),
        fontsize=9,
    )
    fig.tight_layout()
    return fig


def efficiency_png(ff: FrictionFigures, path: Path, note: str = "") -> Path:
    """The catalogue's efficiency against output torque, one curve per input speed."""
    import matplotlib.pyplot as plt

    fig = efficiency_figure(ff, note)
    fig.savefig(path, dpi=110, metadata={"Software": None})
    plt.close(fig)
    return Path(path)
