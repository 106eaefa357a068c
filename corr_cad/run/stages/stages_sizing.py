"""Pipeline stage of the design search (``sizing``): candidates, the front, its scenes.

Registered in :data:`corr_cad.run.stages.stages.STAGES`. The search
(:mod:`corr_cad.run.stages.sizing_search`) screens candidates at the
screening resolution on the run's executor (a process pool, Dask, or this
process: the same rows in the same order on each); the screened front is
then evaluated again at the scene's own resolution, with the model the
scene names, and the front of those full figures is the result. The
scene's own design is evaluated too, as the reference. Files:
``sizing.csv``, ``pareto.csv``, ``pareto.png`` and ``design_NN.toml``.
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.run.scene.scene_schema import SCHEMA
from corr_cad.run.scene.scene_schema_sizing import OBJECTIVES, VARIABLES
from corr_cad.run.stages.context import RunContext, expected_seconds
from corr_cad.run.stages.sizing_candidates import (
    FIGURES,
    OBJECTIVE_FIGURE,
    candidate_data,
    evaluate_chunk,
    needs_efficiency,
)
from corr_cad.run.stages.sizing_search import non_dominated, objective_matrix, search

__all__ = ["sizing", "scene_values", "spearman", "LABELS"]

#: Objective -> axis label.
LABELS = {
    name: f"{name.replace('_', ' ')}" + (f" [{unit}]" if unit else "") + f" ({sense}imise)"
    for name, (sense, unit, _) in OBJECTIVES.items()
}


def scene_values(scene, names) -> dict:
    """The scene's own value of each variable (its design, bearing and first stage)."""
    out = {}
    for name in names:
        section = VARIABLES[name][0]
        if section == "design":
            out[name] = getattr(scene.design, name)
        elif section == "first_stage":
            out[name] = getattr(scene.first_stage.stage, name)
        elif scene.bearing is not None:
            out[name] = getattr(scene.bearing, name)
        else:
            out[name] = scene.life.get(name)
    return out


def spearman(a, b) -> float:
    """Spearman's rank correlation of two equally long sequences (nan below 3 values)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if len(a) < 3:
        return math.nan
    ra = np.argsort(np.argsort(a, kind="stable"), kind="stable").astype(float)
    rb = np.argsort(np.argsort(b, kind="stable"), kind="stable").astype(float)
    if ra.std() == 0 or rb.std() == 0:
        return math.nan
    return float(np.corrcoef(ra, rb)[0, 1])


class _Batches:
    """Candidates evaluated on the run's executor in chunks, rows back in order."""

    def __init__(self, ctx: RunContext, bar=None):
        from corr_cad.tolerance.mc_chunks import IN_FLIGHT_PER_WORKER, executor_workers
        from corr_cad.tolerance.montecarlo import SerialExecutor

        self.executor = ctx.executor or SerialExecutor()
        self.window = executor_workers(self.executor) * IN_FLIGHT_PER_WORKER
        self.sz = ctx.scene.sizing
        self.bar = bar

    def __call__(self, values: list[dict], screening: bool = True) -> list[dict]:
        req, base = self.sz["requirements"], self.sz["base"]
        eff = needs_efficiency(self.sz)
        items = [(i, candidate_data(base, v, req, screening, eff)) for i, v in enumerate(values)]
        size = max(1, math.ceil(len(items) / self.window))
        tasks = [
            self.executor.submit(evaluate_chunk, items[a : a + size], req)
            for a in range(0, len(items), size)
        ]
        rows: list[dict] = []
        for task in tasks:
            part = task.result()
            rows.extend(part)
            if self.bar is not None:
                self.bar.update(len(part))
        return rows


def sizing(ctx: RunContext) -> None:
    from corr_cad.run.progress import Progress

    s = ctx.scene
    sz = s.sizing
    objectives, levels = list(sz["objectives"]), sz["variables"]
    names = list(levels)
    own = scene_values(s, names)
    bar = Progress(
        sz["evaluations"], "      sizing", "candidates", expected=expected_seconds(ctx, "sizing")
    )
    batch = _Batches(ctx, bar)
    found = search(
        levels,
        objectives,
        OBJECTIVE_FIGURE,
        batch,
        sz["evaluations"],
        sz["population"],
        sz["seed"],
        start={n: v for n, v in own.items() if v is not None},
    )
    bar.close()
    rows = []
    for i, (gen, values, row) in enumerate(found, 1):
        rows.append({"candidate": i, "generation": gen, "fidelity": "screening", **values, **row})
    full = _full_front(ctx, rows, objectives, names, own)
    _write(ctx, rows, full, objectives, names)


def _full_front(ctx: RunContext, rows: list[dict], objectives, names, own) -> dict:
    """The screened front (or the nearest misses) at full resolution; the reference."""
    sz = ctx.scene.sizing
    ctx.progress("      sizing: the front again at the scene's own resolution, and its own design")
    batch = _Batches(ctx)
    feasible = [r for r in rows if r["feasible"]]
    if feasible:
        F = objective_matrix(feasible, objectives, OBJECTIVE_FIGURE)
        picked = [feasible[i] for i in non_dominated(F)]
        first = OBJECTIVE_FIGURE[objectives[0]]
        picked.sort(key=lambda r: (r[first], r["candidate"]))
        picked = _picks(picked, 2 * sz["population"])  # the estimate's bound on the second pass
    else:  # nothing fits: the candidates that miss least, for the verdict
        picked = sorted(rows, key=lambda r: r["violation"])[: max(sz["designs"], 5)]
    again = batch([{n: r[n] for n in names} for r in picked] + [{}], screening=False)
    full = []
    for r, row in zip(picked, again[:-1], strict=True):
        full.append({"candidate": r["candidate"], "generation": r["generation"],
                     "fidelity": "full", **{n: r[n] for n in names}, **row})  # fmt: skip
    reference = {"candidate": "reference", "generation": "", "fidelity": "full", **own, **again[-1]}
    pool = [r for r in full if r["feasible"]] + ([reference] if reference["feasible"] else [])
    front = []
    if pool:
        F = objective_matrix(pool, objectives, OBJECTIVE_FIGURE)
        front = [pool[i] for i in non_dominated(F)]
        first = OBJECTIVE_FIGURE[objectives[0]]
        front.sort(key=lambda r: (r[first], str(r["candidate"])))
    ranks, gaps = {}, {}
    for name in objectives:
        col = OBJECTIVE_FIGURE[name]
        pairs = [(p.get(col), f.get(col)) for p, f in zip(picked, full, strict=True)]
        pairs = [(a, b) for a, b in pairs if a is not None and b is not None and b != 0]
        ranks[name] = spearman([a for a, _ in pairs], [b for _, b in pairs])
        gaps[name] = max((abs(a / b - 1.0) for a, b in pairs), default=math.nan)
    return {"screened": picked, "full": full, "reference": reference, "front": front,
            "ranks": ranks, "gaps": gaps}  # fmt: skip


def _picks(front: list[dict], n: int) -> list[dict]:
    """``n`` designs spread along the front (both ends first), in the front's order."""
    if len(front) <= n:
        return list(front)
    idx = sorted({int(round(k * (len(front) - 1) / (n - 1))) for k in range(n)}) if n > 1 else [0]
    return [front[i] for i in idx]


def _write(ctx: RunContext, rows, full: dict, objectives, names) -> None:
    from corr_cad.export.sizing_io import design_toml, pareto_png, write_rows
    from corr_cad.run.stages.sizing_report import verdict

    s, sz = ctx.scene, ctx.scene.sizing
    front, reference = full["front"], full["reference"]
    picks = _picks(front, sz["designs"])
    for k, r in enumerate(picks, 1):
        r["design"] = f"design_{k:02d}.toml"
        data = candidate_data(sz["base"], {n: r[n] for n in names}, sz["requirements"])
        data = {k: data[k] for k in SCHEMA if k in data}  # the sections in the schema's order
        design_toml(
            ctx.out / r["design"],
            data,
            [
                f"Design {k} of the front of the sizing scene {s.name!r} (candidate "
                f"{r['candidate']}); run it with",
                f"  corr-cad run {r['design']} --out design_{k:02d}",
                "The figures of pareto.csv are this scene's: datasheet.json and manifest.json.",
            ],
        )
        ctx.files.append(r["design"])
    head = ["candidate", "generation", "fidelity", *names, *FIGURES]
    tail = ["feasible", "refused_by", "reason"]
    write_rows(ctx.out / "sizing.csv", head + tail, rows + full["full"] + [reference])
    write_rows(ctx.out / "pareto.csv", ["design", *head, "feasible"], front)
    axes = [(OBJECTIVE_FIGURE[o], LABELS[o]) for o in objectives]
    title = f"sizing: {len(rows)} candidates, front of {len(front)} (full model)"
    pareto_png(ctx.out / "pareto.png", rows, front, reference, axes, title)
    ctx.files.extend(["sizing.csv", "pareto.csv", "pareto.png"])
    summary = {
        "objectives": objectives,
        "evaluations": len(rows),
        "feasible": sum(1 for r in rows if r["feasible"]),
        "front": len(front),
        "designs": [r["design"] for r in picks],
        "seed": sz["seed"],
        "screening_rank_correlation": full["ranks"],
        "screening_max_relative_difference": full["gaps"],
        "reference": {k: reference.get(k) for k in (*FIGURES, "feasible", "refused_by")},
    }
    if not front:
        summary["failed"] = [verdict(s, rows + full["full"] + [reference], full["full"])]
    ctx.manifest["sizing"] = summary
    ctx.progress(
        f"      sizing: {len(rows)} candidates, {summary['feasible']} feasible; front of "
        f"{len(front)}, {len(picks)} written as scenes"
    )
