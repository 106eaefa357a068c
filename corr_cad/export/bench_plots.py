"""The benchmarks' plots: one figure per study, labels that never print over each other."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

__all__ = ["figure", "place_labels", "progress_png", "resources_png"]


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


def resources_png(path: Path, rows: list) -> Path:
    """Estimate over measured, per scene: memory (the guarantee: >= 1), time and files.

    ``rows``: ``[scene, est_MB, peak_MB, memory_ratio, est_s, s, time_ratio,
    est_out_MB, out_MB, output_ratio, ...]`` (``corr_cad.run.bench.bench_resources``).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.ticker import FuncFormatter, NullFormatter

    plain = FuncFormatter(lambda v, _: f"{v:g}")
    names = [f"{k + 1}  {r[0]}" for k, r in enumerate(rows)]
    y = np.arange(len(rows))
    fig, (ax, ax2) = plt.subplots(
        1, 2, figsize=(12, 0.45 * len(rows) + 2.2), gridspec_kw={"width_ratios": [3, 2]}
    )
    for k, (col, label, color) in enumerate(
        ((3, "memory", "C0"), (6, "time", "C1"), (9, "files", "C2"))
    ):
        vals = np.array([r[col] for r in rows], dtype=float)
        ax.barh(y + (k - 1) * 0.27, vals, height=0.27, color=color, label=label)
    ax.axvline(1.0, color="k", lw=1.0)
    ax.set_xscale("log")
    ax.xaxis.set_major_formatter(plain)
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xticks([0.25, 0.5, 1, 2, 4])
    ax.set_yticks(y, names, fontsize=8)
    ax.invert_yaxis()
    ax.set_xlabel("estimate / measured (memory: peak RSS of the process tree)")
    ax.set_title("resource estimate against whole runs (memory must stay >= 1)", fontsize=10)
    ax.legend(fontsize=8, loc="lower right")
    ax.grid(alpha=0.3, which="both", axis="x")
    est = np.array([r[1] for r in rows], dtype=float)
    peak = np.array([r[2] for r in rows], dtype=float)
    ax2.loglog(peak, est, "o", color="C0")
    lo, hi = 0.8 * min(peak.min(), est.min()), 1.25 * max(peak.max(), est.max())
    ax2.plot([lo, hi], [lo, hi], "k-", lw=1.0, label="estimate = peak")
    ax2.plot([lo, hi], [2 * lo, 2 * hi], "k:", lw=0.8, label="estimate = 2 x peak")
    ax2.set_xlim(lo, hi)
    ax2.set_ylim(lo, hi * 2)
    ticks = [t for t in (50, 100, 200, 500, 1000, 2000, 5000, 10000) if lo <= t <= 2 * hi]
    for axis in (ax2.xaxis, ax2.yaxis):
        axis.set_major_formatter(plain)
        axis.set_minor_formatter(NullFormatter())
        axis.set_ticks(ticks)
    ax2.set_xlim(lo, hi)
    ax2.set_ylim(lo, hi * 2)
    ax2.set_xlabel("measured peak memory [MB]")
    ax2.set_ylabel("estimated peak memory [MB]")
    ax2.legend(fontsize=8, loc="upper left")
    ax2.grid(alpha=0.3, which="both")
    fig.tight_layout()
    place_labels(ax2, [(x, e, str(k + 1)) for k, (x, e) in enumerate(zip(peak, est, strict=True))])
    fig.savefig(path, dpi=120, metadata={"Software": None})
    plt.close(fig)
    return path


def progress_png(path: Path, rows: list, total: float) -> Path:
    """Stated against actual time left over the run, and the gaps between lines.

    ``rows``: ``[t_s, gap_s, done, total, time_left_from, stated_left_s,
    actual_left_s]`` (``corr_cad.run.bench.bench_progress``); ``total``: the run's s.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 4.5))
    t = [r[0] for r in rows]
    end = rows[-1][0] + rows[-1][6] if rows else total
    ax.plot([0, end], [end, 0], "k-", lw=1.0, label="actual time left (of the stage)")
    for kind, marker in (("heartbeat", "^"), ("estimate", "s"), ("measured", "o")):
        pts = [(r[0], r[5]) for r in rows if r[4] == kind]
        if pts:
            ax.plot(*zip(*pts, strict=True), marker, label=f"stated ({kind})")
    ax.set_xlabel("time since the start of the run, s")
    ax.set_ylabel("time left, s")
    ax.set_title("time left stated by the progress lines", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    ax2.bar(range(1, len(rows) + 1), [r[1] for r in rows], color="C1")
    ax2.axhline(5.0, color="k", lw=1.0, ls=":", label="interval 5 s")
    ax2.set_xlabel("progress line")
    ax2.set_ylabel("gap since the line before (the first: the stage's start), s")
    ax2.xaxis.get_major_locator().set_params(integer=True)
    ax2.set_title(f"{len(t)} lines over {total:.1f} s", fontsize=10)
    ax2.legend(fontsize=8)
    ax2.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    fig.savefig(path, dpi=120, metadata={"Software": None})
    plt.close(fig)
    return path
