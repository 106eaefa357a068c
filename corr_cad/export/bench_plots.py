"""The benchmarks' plots: one figure per study, labels that never print over each other."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

__all__ = ["figure", "place_labels"]


def figure(out: Path, name: str, draw: Callable) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 5))
    labels = draw(ax)
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    if labels:
        # Room on the right for the labels, which run rightwards from their points.
        lo, hi = ax.get_xlim()
        ax.set_xlim(lo, hi * 4.0 if ax.get_xscale() == "log" else hi + 0.25 * (hi - lo))
        place_labels(ax, labels)
    fig.savefig(out / name, dpi=120, metadata={"Software": None})
    plt.close(fig)
    return out / name


def place_labels(ax, labels: list[tuple[float, float, str]], size: float = 7.0) -> None:
    """Annotate points so that no two labels print over each other.

    Points whose labels would collide (in display space) get their labels
    stacked downwards, one line each.
    """
    ax.figure.canvas.draw()  # fix the limits and transforms
    placed: list[tuple[float, float]] = []
    line = size * 1.35 * ax.figure.dpi / 72.0  # one text line, pixels
    for x, y, text in labels:
        px, py = ax.transData.transform((x, y))
        k = 0
        while any(abs(px - qx) < 90 and abs(py - k * line - qy) < line for qx, qy in placed):
            k += 1
        placed.append((px, py - k * line))
        ax.annotate(
            text,
            (x, y),
            xytext=(4, -k * size * 1.35 + 2),
            textcoords="offset points",
            fontsize=size,
            annotation_clip=False,
        )
