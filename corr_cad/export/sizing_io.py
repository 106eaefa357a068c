"""Files of the design search: ``sizing.csv``, ``pareto.csv``, ``pareto.png``, ``design_NN.toml``.

Numbers are written as Python writes a float (``repr``: the shortest text
that reads back to the same double), so a figure read from the CSV is the
figure computed, and the same search gives the same bytes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from corr_cad.export import plots
from corr_cad.export.files import write_csv, write_new_text
from corr_cad.figure_text import figure

__all__ = ["write_rows", "pareto_png", "design_toml", "report_table"]

plt = plots.plt


def _cell(v) -> object:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float) and not np.isfinite(v):
        return ""
    return v


def write_rows(path: Path, header: list[str], rows: list[dict]) -> Path:
    """A CSV of ``rows`` (dicts) in the order of ``header``; a missing value is empty."""
    return write_csv(path, header, ([_cell(r.get(k)) for k in header] for r in rows))


def pareto_png(
    path: Path,
    rows: list[dict],
    front: list[dict],
    reference: dict | None,
    axes: list[tuple[str, str]],
    title: str,
) -> Path:
    """The candidates and the front in the plane of the first two objectives.

    ``axes``: ``(column, label)`` of each objective (a third one colours the
    front's points); screened feasible candidates grey, infeasible ones as
    light crosses, the front (full model) joined in order of the first
    objective (two objectives) with each design file's number, the reference a star.
    """
    (cx, lx), (cy, ly) = axes[0], axes[1]

    def xy(rs):
        pts = [(r.get(cx), r.get(cy)) for r in rs]
        pts = [(x, y) for x, y in pts if x is not None and y is not None]
        return np.array(pts, dtype=float).reshape(-1, 2)

    fig, ax = plt.subplots(figsize=(7.5, 5.5))
    bad = xy([r for r in rows if not r.get("feasible")])
    good = xy([r for r in rows if r.get("feasible")])
    if len(bad):
        ax.plot(bad[:, 0], bad[:, 1], "x", color="#e8a0a0", ms=4, label="infeasible (screening)")
    if len(good):
        ax.plot(good[:, 0], good[:, 1], ".", color="0.6", ms=5, label="feasible (screening)")
    if front:
        pts = xy(front)
        if len(axes) == 2:  # a third objective's front is no curve in this plane
            order = np.argsort(pts[:, 0], kind="stable")
            ax.plot(pts[order, 0], pts[order, 1], "-", color="C0", lw=1.2)
        colour = None
        if len(axes) > 2:
            colour = [r.get(axes[2][0]) for r in front]
        sc = ax.scatter(pts[:, 0], pts[:, 1], c=colour if colour else "C0", s=36, zorder=3,
                        label="front (full model)")  # fmt: skip
        if colour:
            fig.colorbar(sc, ax=ax, label=axes[2][1])
        for r, (x, y) in zip(front, pts, strict=True):
            if r.get("design"):
                ax.annotate(r["design"].removeprefix("design_").removesuffix(".toml"), (x, y),
                            textcoords="offset points", xytext=(5, 4), fontsize=8)  # fmt: skip
    if reference is not None and reference.get(cx) is not None and reference.get(cy) is not None:
        state = "meets" if reference.get("feasible") else "fails"
        ax.plot(reference[cx], reference[cy], "*", color="C3", ms=14, zorder=4,
                label=f"scene's own design ({state} the requirements)")  # fmt: skip
    ax.set_xlabel(lx)
    ax.set_ylabel(ly)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    ax.xaxis.set_major_formatter(plt.FuncFormatter(lambda v, _p: figure(v)))
    ax.yaxis.set_major_formatter(plt.FuncFormatter(lambda v, _p: figure(v)))
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    return plots._save(fig, path)


def _nested(data: dict) -> dict:
    """``{"bearings.eccentric": {...}}`` as the TOML table ``[bearings.eccentric]``."""
    out: dict = {}
    for k, v in data.items():
        head, _, tail = k.partition(".")
        if tail:
            out.setdefault(head, {})[tail] = v
        else:
            out[k] = {**out.get(k, {}), **v} if isinstance(v, dict) else v
    return out


def design_toml(path: Path, data: dict, comment: list[str]) -> Path:
    """A candidate's scene as a new TOML file, with ``comment`` lines above it."""
    import tomli_w

    head = "".join(f"# {line}\n" for line in comment)
    return write_new_text(path, head + "\n" + tomli_w.dumps(_nested(data)))


#: ``pareto.csv`` columns the report shows, with their headings.
_REPORT_COLUMNS = {
    "design": "design",
    "mass_kg": "mass [kg]",
    "torsional_rigidity_Nm_per_arcmin": "rigidity [N*m/arcmin]",
    "lost_motion_arcmin": "lost motion [arcmin]",
    "efficiency": "efficiency",
    "life_h": "life L10 [h]",
    "outer_diameter_mm": "outer diameter [mm]",
    "length_mm": "length [mm]",
    "total_ratio": "ratio",
}


def report_table(summary: dict, pareto_csv: Path) -> dict:
    """The report's section of the design search: a line, the verdict, the front's table."""
    import csv

    rows = []
    if Path(pareto_csv).is_file():
        with open(pareto_csv, newline="") as f:
            rows = list(csv.DictReader(f))
    cols = [c for c in _REPORT_COLUMNS if any(r.get(c) for r in rows)] or ["design"]

    def cell(c: str, v: str) -> str:
        return v if c == "design" or v == "" else figure(float(v))

    return {
        "summary": (
            f"{summary['evaluations']} candidates for the objectives "
            f"{', '.join(summary['objectives'])} (seed {summary['seed']}), "
            f"{summary['feasible']} feasible at screening; the front at full resolution holds "
            f"{summary['front']}, written as {', '.join(summary['designs']) or 'none'}."
        ),
        "failed": "; ".join(summary.get("failed", [])),
        "header": [_REPORT_COLUMNS[c] for c in cols],
        "rows": [[cell(c, r.get(c, "")) for c in cols] for r in rows],
    }
