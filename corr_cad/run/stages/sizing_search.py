"""The design search: pymoo's NSGA-II over integer variables, and the Pareto front.

Every variable is an index into its levels (whole numbers, a grid, or a
list of standard sizes: :func:`corr_cad.run.scene.scene_schema_sizing.variable_levels`),
so NSGA-II runs with integer sampling, simulated binary crossover and
polynomial mutation rounded to whole indices (pymoo's integer recipe). The
search is driven by ask and tell: each generation's new candidates go to
``evaluate_batch`` at once (a pool, Dask or this process), and a candidate
seen before is not evaluated again. Objectives are minimised (a maximised
figure negated); the constraint is the sum of the requirements' relative
violations, so feasible designs dominate and infeasible ones are ranked by
how far they miss. Seeded: the same seed and the same figures give the same
candidates in the same order.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from corr_cad.run.scene.scene_schema_sizing import OBJECTIVES

__all__ = ["search", "objective_matrix", "non_dominated", "hypervolume_2d", "BIG"]

#: Objective value of a candidate without figures (the loader or a stage refused it).
BIG = 1e30
#: Generations in a row without a new candidate after which the space counts as exhausted.
STALL_GENERATIONS = 25


def objective_matrix(rows: list[dict], objectives: list[str], columns: dict) -> np.ndarray:
    """``(n, k)`` objectives to minimise: maximised figures negated, missing ones :data:`BIG`."""
    out = np.full((len(rows), len(objectives)), BIG)
    for i, row in enumerate(rows):
        for j, name in enumerate(objectives):
            v = row.get(columns[name])
            if v is not None and math.isfinite(v):
                out[i, j] = -v if OBJECTIVES[name][0] == "max" else v
    return out


def non_dominated(F: np.ndarray) -> np.ndarray:
    """Indices of the rows of ``F`` (minimised) that no other row dominates, in order."""
    keep = []
    for i in range(len(F)):
        worse = np.all(F <= F[i], axis=1) & np.any(F < F[i], axis=1)
        if not worse.any():
            keep.append(i)
    return np.asarray(keep, dtype=int)


def hypervolume_2d(F: np.ndarray, ref: np.ndarray) -> float:
    """Area dominated by the 2-objective points ``F`` (minimised) up to ``ref``."""
    pts = F[np.all(F < ref, axis=1)]
    if len(pts) == 0:
        return 0.0
    pts = pts[np.lexsort((pts[:, 1], pts[:, 0]))]
    area, best = 0.0, ref[1]
    for x, y in pts:
        if y < best:
            area += (ref[0] - x) * (best - y)
            best = y
    return float(area)


def _problem(levels: list[int], n_obj: int):
    from pymoo.core.problem import Problem

    return Problem(
        n_var=len(levels),
        n_obj=n_obj,
        n_ieq_constr=1,
        xl=np.zeros(len(levels)),
        xu=np.asarray(levels, dtype=float) - 1,
        vtype=int,
    )


def search(
    levels: dict[str, tuple],
    objectives: list[str],
    columns: dict,
    evaluate_batch: Callable[[list[dict]], list[dict]],
    evaluations: int,
    population: int,
    seed: int,
    start: dict | None = None,
) -> list[tuple[int, dict, dict]]:
    """Run NSGA-II; every evaluated candidate as ``(generation, values, row)`` in order.

    ``levels``: each variable's values; ``evaluate_batch(list of values) ->
    rows`` (``feasible``, ``violation`` and the figure ``columns`` of the
    objectives); ``start``: values put first into the first population (the
    scene's own design, snapped to the levels).
    """
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.core.evaluator import Evaluator
    from pymoo.core.termination import NoTermination
    from pymoo.operators.crossover.sbx import SBX
    from pymoo.operators.mutation.pm import PM
    from pymoo.operators.repair.rounding import RoundingRepair
    from pymoo.problems.static import StaticProblem

    names = list(levels)
    sizes = [len(levels[n]) for n in names]
    rng = np.random.default_rng(seed)
    x0 = np.column_stack([rng.integers(0, s, size=population) for s in sizes])
    if start is not None:  # a variable the scene leaves unset starts at random
        for j, n in enumerate(names):
            if n in start:
                x0[0, j] = int(np.argmin(np.abs(np.asarray(levels[n]) - start[n])))
    problem = _problem(sizes, len(objectives))
    algorithm = NSGA2(
        pop_size=population,
        sampling=x0,
        crossover=SBX(prob=0.9, eta=15, vtype=float, repair=RoundingRepair()),
        mutation=PM(eta=20, vtype=float, repair=RoundingRepair()),
        eliminate_duplicates=True,
    )
    algorithm.setup(problem, termination=NoTermination(), seed=seed, verbose=False)
    seen: dict[tuple, dict] = {}
    out: list[tuple[int, dict, dict]] = []
    generation, idle = 0, 0
    while len(seen) < evaluations and idle < STALL_GENERATIONS:
        pop = algorithm.ask()
        if pop is None or len(pop) == 0:  # no new offspring: the space is spent
            break
        X = np.rint(pop.get("X")).astype(int)
        keys = [tuple(int(i) for i in x) for x in X]
        new = list(dict.fromkeys(k for k in keys if k not in seen))
        new = new[: evaluations - len(seen)]
        values = [{n: levels[n][k[j]] for j, n in enumerate(names)} for k in new]
        rows = evaluate_batch(values) if new else []
        for k, v, row in zip(new, values, rows, strict=True):
            seen[k] = row
            out.append((generation, v, row))
        idle = 0 if new else idle + 1
        if any(k not in seen for k in keys):  # the budget ended inside this generation
            break
        got = [seen[k] for k in keys]
        F = objective_matrix(got, objectives, columns)
        G = np.array([[min(r["violation"], BIG)] for r in got])
        Evaluator().eval(StaticProblem(problem, F=F, G=G), pop)
        algorithm.tell(infills=pop)
        generation += 1
    return out
