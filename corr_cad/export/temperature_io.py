"""Files of ``[thermal.test]``: temperature.csv and temperature.png.

``temperature.csv``: one row per ``step_min`` of the programme (and its
last point): time, the input speed and output torque of the programme at
that time, the oil (node) temperature and the losses heating it.
``temperature.png``: the temperature against time, the input speed on a
second axis.
"""

from __future__ import annotations

from pathlib import Path

from corr_cad.export.files import write_columns

__all__ = ["TEMPERATURE_COLUMNS", "write_temperature_csv", "temperature_png"]

TEMPERATURE_COLUMNS = (
    "time_min",
    "input_speed_rpm",
    "output_torque_Nm",
    "oil_temperature_C",
    "loss_W",
)


def write_temperature_csv(rows: dict, path: Path) -> Path:
    """``temperature.csv`` from the test's columns (:data:`TEMPERATURE_COLUMNS`)."""
    return write_columns(
        path,
        TEMPERATURE_COLUMNS,
        [rows[k] for k in TEMPERATURE_COLUMNS],
        ["%.6g", "%.6g", "%.6g", "%.6f", "%.6g"],
    )


def temperature_png(test: dict, path: Path, name: str = "") -> Path:
    """The oil temperature over the programme, the input speed on the right axis."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = test["rows"]
    fig, ax = plt.subplots(figsize=(7, 4.4))
    few = len(rows["time_min"]) <= 60  # readings a bench would take: marked
    ax.plot(
        rows["time_min"],
        rows["oil_temperature_C"],
        color="C3",
        marker="o" if few else None,
        ms=3,
        label="oil temperature",
    )
    ax.set_xlabel("time [min]")
    ax.set_ylabel("oil temperature [C]", color="C3")
    ax.grid(alpha=0.3)
    ax2 = ax.twinx()
    ax2.plot(rows["time_min"], rows["input_speed_rpm"], color="0.45", ls="--", label="input speed")
    ax2.set_ylabel(f"input speed ({test['input_speed_of']}) [r/min]", color="0.35")
    ax2.set_ylim(bottom=0.0)
    lines = ax.get_lines() + ax2.get_lines()
    ax.legend(lines, [ln.get_label() for ln in lines], fontsize=8, loc="lower right")
    ax.set_title(
        (f"{name}: " if name else "")
        + f"[thermal.test], final {test['final_temperature_C']:.1f} C, "
        f"max {test['max_temperature_C']:.1f} C\none-node network, Palmgren drag + "
        "Coulomb friction, viscosity at the oil temperature",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110, metadata={"Software": None})
    plt.close(fig)
    return Path(path)
