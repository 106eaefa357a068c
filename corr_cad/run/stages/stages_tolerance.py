"""Pipeline stages under tolerances: Monte Carlo, allocation and parameter sweeps.

Registered in :data:`corr_cad.run.stages.stages.STAGES`.
"""

from __future__ import annotations

import contextlib

import numpy as np

from corr_cad.errors import SceneError, SolverError
from corr_cad.figure_text import figure
from corr_cad.mechanics.row.solver import solve_forces
from corr_cad.run.stages.context import (
    RunContext,
    chain_kwargs,
    drive_kwargs,
    expected_seconds,
    psi_contact_limit,
    scene_errors,
)
from corr_cad.run.stages.plot_workers import draw, wait
from corr_cad.run.stages.stages_drive import samples_chain

#: Monte Carlos of one allocation search, typically (a first one at 0, the
#: doublings, then the bisection to 2 %; ``allocate`` reports the exact count).
#: The allocation stage's cost estimate counts with the same number.
ALLOCATION_EVALUATIONS = 12


def _datasheet_mc(scene):
    """The Monte Carlo's datasheet pass of a scene, or None when it does not ask for it."""
    from corr_cad.run.scene.scene_montecarlo import wants_datasheet_metrics

    if not wants_datasheet_metrics(scene):
        return None
    from corr_cad.run.stages.stages_datasheet import datasheet_spec
    from corr_cad.tolerance.mc_datasheet import DatasheetMC

    mc = scene.montecarlo
    return DatasheetMC(
        datasheet_spec(scene),
        binding_pressure_MPa=mc["binding_pressure_MPa"],
        positions_per_mesh=mc["datasheet_positions_per_mesh"],
    )


class _RowStream:
    """Writes ``montecarlo.csv`` a chunk of samples at a time, as the Monte Carlo returns them.

    The columns: ``sample``, each tolerance's ``<kind>_magnitude``, then the
    metrics; the bytes are those of :func:`~corr_cad.export.files.write_columns`
    over the whole table (each row is formatted on its own).
    """

    def __init__(self, handle) -> None:
        self.f = handle
        self.fmts: list[str] | None = None

    def __call__(self, lo: int, magnitudes: dict, metrics: dict) -> None:
        from corr_cad.export.files import format_columns

        n = len(next(iter(metrics.values())))
        if self.fmts is None:
            header = ["sample"] + [f"{k}_magnitude" for k in magnitudes] + list(metrics)
            self.f.write(",".join(header) + "\n")
            self.fmts = ["%d"] + ["%.9g"] * (len(header) - 1)
        cols = [np.arange(lo, lo + n), *magnitudes.values(), *metrics.values()]
        self.f.write(format_columns(cols, self.fmts))


def _drive_mc(ctx: RunContext) -> dict | None:
    """The Monte Carlo's ``drive`` argument under ``model = "drive"`` (None: the paper's row)."""
    s = ctx.scene
    if not s.solver.drive:
        return None
    kw = drive_kwargs(ctx)
    keys = ("errors_b", "bearing", "bearing_b", "contact_model", "crank", "bodies")
    return {k: kw[k] for k in keys if k in kw}  # the chain's keys only where it has them


def _sweep_model(ctx: RunContext) -> dict | None:
    """The sweeps' ``drive`` argument: the model and contact law (None: the paper's row)."""
    s = ctx.scene
    if s.solver.drive:
        return {
            "model": "drive",
            "bearing": s.bearing,
            "bearing_b": s.bearing_b,
            "contact_model": s.solver.contact_model,
            **chain_kwargs(ctx, per_design=True),
        }
    if s.solver.contact_law != "paper":
        return {"model": "paper", "contact_model": s.solver.contact_model}
    return None


def _montecarlo(ctx: RunContext) -> None:
    from corr_cad.export.files import atomic_writer, write_json
    from corr_cad.run.progress import Progress
    from corr_cad.run.stages.stages_datasheet import add_as_built
    from corr_cad.tolerance.checks import evaluate_failure_probability
    from corr_cad.tolerance.montecarlo import monte_carlo

    s = ctx.scene
    mc_cfg = s.montecarlo
    n = mc_cfg["samples"]
    sheet = _datasheet_mc(s)
    bar = Progress(n, "      montecarlo", "samples", expected=expected_seconds(ctx, "montecarlo"))

    def tick(done: int, total: int) -> None:
        bar.update(done - bar.done)

    executor, nominal_of = _nominal_ahead(ctx, mc_cfg["positions"], sheet)
    ahead = _local_pool(ctx) and ctx.plotter is None  # else drawn by a plot worker
    with _plots_ahead(ahead), atomic_writer(ctx.out / "montecarlo.csv") as f:
        res = monte_carlo(
            s.design,
            s.load.input_torque,
            s.tolerances,
            n,
            mc_cfg["seed"],
            mc_cfg["positions"],
            load_share=s.solver.load_share,
            base_errors=scene_errors(ctx),
            executor=executor,
            progress=tick,
            psi_contact_limit=psi_contact_limit(ctx),
            datasheet=sheet,
            sink=_RowStream(f),
            drive=_drive_mc(ctx),
        )
        bar.close()
        if not res.success:
            raise SolverError("Monte Carlo: the force solver did not converge for some samples")
    checks = s.checks
    if s.first_stage is not None:  # the whole drive's limits, on the second stage's samples
        from corr_cad.run.stages.stages_first_stage import second_stage_limits

        checks, whole = second_stage_limits(ctx, s.checks, sheet.spec if sheet else None)
    summary = res.summary(checks)
    if s.first_stage is not None and whole:
        summary["whole_drive_limits"] = whole
    summary.update({"seed": mc_cfg["seed"], "positions": mc_cfg["positions"]})
    summary["tolerances"] = {k: d.__dict__ for k, d in s.tolerances.items()}
    nominal = nominal_of()
    if sheet is not None:
        summary["datasheet"] = {
            "rated_torque_Nm": sheet.spec.rated_torque / 1000.0,
            "positions_per_mesh": sheet.positions_per_mesh,
            "binding_pressure_MPa": sheet.binding_pressure_MPa,
        }
    if s.solver.drive:
        summary.update(_drive_model_meta(s, sheet))
    summary["nominal"] = nominal
    if s.life:
        summary["life_h"] = _life_under_tolerances(ctx)
    write_json(ctx.out / "montecarlo_summary.json", summary)
    picture = draw(  # in a plot worker where the CLI started one, while this goes on
        ctx.plotter,
        "corr_cad.export.plots_tolerance",
        "ranked_montecarlo_png",
        res.metrics,
        checks,
        ctx.out / "montecarlo.png",
        summary,
        nominal,
        s.design,
        s.load.input_torque,
        s.tolerances,
        s.montecarlo["binding_pressure_MPa"] if "binds" in res.metrics else None,
    )
    try:  # while the figure is drawn: the manifest's section and the gates
        ctx.manifest["montecarlo"] = {
            k: summary[k]
            for k in (
                "samples",
                "failure_probability",
                "percentiles",
                "nominal",
                "sensitivity",
                "binding_probability",
                "life_h",
            )
            if k in summary
        }
        if samples_chain(s) is not None:  # the console says what the samples solve on
            ctx.manifest["montecarlo"]["samples_chain"] = samples_chain(s)
        add_as_built(ctx)  # the datasheet's page gives the figures as built beside the nominal
        gate = evaluate_failure_probability(summary["failure_probability"], s.checks)
        allowed = s.checks.max_binding_probability
        if allowed is not None:
            b = summary["binding_probability"]
            gate["max_binding_probability"] = {
                "probability": b["probability"],
                "allowed": allowed,
                "passed": bool(b["probability"] <= allowed),
                "standard_error": b["standard_error"],
                "wilson_interval": b["wilson_interval"],
            }
        if gate:
            ctx.manifest.setdefault("checks", {})["montecarlo"] = gate
            for name, g in gate.items():
                state = "pass" if g["passed"] else "FAIL"
                ctx.progress(
                    f"      check montecarlo {name}: {state} (failure probability "
                    f"{figure(g['probability'])}, allowed {figure(g['allowed'])})"
                )
    finally:
        wait([picture])
    ctx.files.extend(["montecarlo.csv", "montecarlo_summary.json", "montecarlo.png"])


def _drive_model_meta(s, sheet) -> dict:
    """``montecarlo_summary.json``'s statement of the drive model (and of its binding)."""
    from corr_cad.run.stages.stages_drive import model_description

    out = {"model": model_description(s)}
    chain = samples_chain(s)
    if chain is not None:
        out["model"]["samples_chain"] = chain
    if sheet is not None:
        from corr_cad.tolerance.mc_drive_datasheet import BINDING_DEFINITION

        out["model"]["binding"] = BINDING_DEFINITION
    return out


def _life_under_tolerances(ctx: RunContext) -> dict:
    """``[life]`` with a Monte Carlo: L10 percentiles over its first samples."""
    from corr_cad.run.stages.stages_datasheet import _life_spec, friction_spec, rated_torque_Nmm
    from corr_cad.tolerance.mc_life import life_percentiles, life_samples

    s = ctx.scene
    friction, life = friction_spec(s)
    n = min(s.montecarlo["samples"], s.life["montecarlo_samples"])
    ctx.progress(f"      life under tolerances: {n} samples")
    lives = life_samples(
        s.design,
        scene_errors(ctx),
        s.tolerances,
        n,
        s.montecarlo["seed"],
        life,
        friction,
        rated_torque_Nmm(s),
        load_share=s.solver.load_share,
        variants=s.solver.variants,
        psi_contact_limit=psi_contact_limit(ctx),
        positions_per_mesh=s.friction["positions_per_mesh"],
        draws=s.montecarlo["samples"],
        drive=_drive_mc(ctx),
        life_b=_life_spec(s, s.bearing if s.bearing_b is None else s.bearing_b),
    )
    return life_percentiles(lives, model="drive" if s.solver.drive else "paper")


def _nominal_metrics(ctx: RunContext, positions: int, sheet=None) -> dict:
    """The Monte Carlo metrics of the scene's own design and errors (no tolerance drawn)."""
    from corr_cad.mechanics.row.solver import cycle_angles

    s = ctx.scene
    if s.solver.drive:
        from corr_cad.mechanics.drive.drive import DriveSolver
        from corr_cad.tolerance.montecarlo_drive import drive_metrics

        kw = drive_kwargs(ctx)
        kw.pop("variants")
        solver = DriveSolver(s.design, cycle_angles(positions), **kw)
        res = solver.result(s.load.input_torque)
        interval = solver.free_interval(solve=False)  # its width: the backlash
        out = drive_metrics(res, interval, float(s.design.roller_count))
        if sheet is not None:
            out.update(_nominal_drive_datasheet(ctx, sheet))
        return out
    return _nominal_task(*_nominal_inputs(ctx, positions, sheet))


def _nominal_inputs(ctx: RunContext, positions: int, sheet=None) -> tuple:
    """:func:`_nominal_task`'s arguments for the paper's row (plain, picklable values)."""
    s = ctx.scene
    return (
        s.design,
        s.load.input_torque,
        positions,
        s.solver.load_share,
        scene_errors(ctx),
        sheet,
        psi_contact_limit(ctx),
    )


def _nominal_task(design, torque, positions, load_share, base, sheet, psi_limit) -> dict:
    """The paper's row's nominal metrics, run in the stage or in a pool worker."""
    from corr_cad.mechanics.row.solver import cycle_angles
    from corr_cad.tolerance.checks import sample_metrics

    res = solve_forces(design, torque, cycle_angles(positions), load_share=load_share, errors=base)
    out = {k: float(v[0]) for k, v in sample_metrics(res, 1).items()}
    if sheet is not None:
        from corr_cad.tolerance.mc_datasheet import datasheet_chunk, grid_positions
        from corr_cad.tolerance.montecarlo import _sample_errors

        grid = grid_positions(design, base, (), sheet.positions_per_mesh)
        errors = _sample_errors(base, {}, {}, 1, design.roller_count)
        extra, _ = datasheet_chunk(design, errors, 1, sheet, grid, load_share, psi_limit, base)
        out.update({k: float(v[0]) for k, v in extra.items()})
    return out


def _nominal_drive_datasheet(ctx: RunContext, sheet) -> dict:
    """The drive's datasheet metrics of the scene's own errors (no tolerance drawn)."""
    from corr_cad.tolerance.mc_drive_datasheet import drive_datasheet_samples, drive_grid

    s = ctx.scene
    base, base_b = scene_errors(ctx), drive_kwargs(ctx)["errors_b"]
    grid = drive_grid(s.design, base, base_b, (), sheet.positions_per_mesh)
    extra, ok = drive_datasheet_samples(
        s.design, [(base, base_b)], sheet, grid, psi_contact_limit(ctx), _drive_mc(ctx)
    )
    if not ok:
        raise SolverError("Monte Carlo: the drive's nominal datasheet metrics did not converge")
    return {k: float(v[0]) for k, v in extra.items()}


def _local_pool(ctx: RunContext) -> bool:
    """Does the paper's row's Monte Carlo run on a local process pool?

    (Not serial, not on Dask, not under the drive model.)"""
    from concurrent.futures import Executor

    return not ctx.scene.solver.drive and isinstance(ctx.executor, Executor)


def _nominal_ahead(ctx: RunContext, positions: int, sheet=None):
    """The Monte Carlo's executor and a call that returns the nominal metrics
    (raising what their computation raised).

    On a local process pool the nominal metrics ride in the pool's first task,
    before the first chunk of samples (:class:`_NominalFirst`): one worker loads
    the compiled kernels for both, and the stage itself never imports numba
    (half a second of the stage's fixed cost); with one chunk of samples the
    other workers have nothing to load. The same code on the same machine: the
    same numbers. In the stage otherwise (serial, Dask, the drive model)."""
    if not _local_pool(ctx):
        return ctx.executor, lambda: _nominal_metrics(ctx, positions, sheet)
    pool = _NominalFirst(ctx.executor, _nominal_inputs(ctx, positions, sheet))
    return pool, pool.nominal


def _with_nominal(nominal_args: tuple, fn, args: tuple) -> tuple:
    """A pool task: :func:`_nominal_task`, then ``fn(*args)`` (the first chunk)."""
    return _nominal_task(*nominal_args), fn(*args)


class _NominalFirst:
    """The local pool as the Monte Carlo sees it: its first task carries the
    nominal metrics' computation (:func:`_with_nominal`), the others go as they
    come. :meth:`nominal` returns the metrics once that task is done."""

    def __init__(self, pool, nominal_args: tuple) -> None:
        from corr_cad.tolerance.mc_chunks import executor_workers

        self.pool = pool
        self._max_workers = executor_workers(pool)  # the chunk sizing's worker count
        self.nominal_args = nominal_args
        self.first = None

    def submit(self, fn, *args):
        if self.first is not None:
            return self.pool.submit(fn, *args)
        self.first = self.pool.submit(_with_nominal, self.nominal_args, fn, args)
        return _Second(self.first)

    def nominal(self) -> dict:
        if self.first is None:  # no sample submitted (not reached: samples >= 1)
            return _nominal_task(*self.nominal_args)
        return self.first.result()[0]


class _Second:
    """The first chunk's share of :func:`_with_nominal`'s future."""

    def __init__(self, task) -> None:
        self.task = task

    def result(self):
        return self.task.result()[1]

    def done(self) -> bool:
        return self.task.done()


@contextlib.contextmanager
def _plots_ahead(pooled: bool):
    """While the local pool's workers run the nominal task and the samples, a
    thread of the main process imports matplotlib and the plot module that draws
    ``montecarlo.png`` (0.3 s of the stage's fixed cost, overlapped with the
    samples). The main process meanwhile mostly waits on the pool and never
    loads numba (:func:`_nominal_ahead`), whose loading would hold the GIL.
    Without a local pool (``pooled`` false) the stage imports it at the plot.
    Left when the thread is done; a failed import is raised again by the
    stage's own import at the plot."""
    import threading

    if not pooled:  # the stage computes the nominal metrics itself
        yield
        return

    def load() -> None:
        try:
            import corr_cad.export.plots_tolerance  # noqa: F401
        except BaseException:  # noqa: BLE001 - the stage's own import raises it again
            pass

    t = threading.Thread(target=load, name="corr-cad-import-plots", daemon=True)
    t.start()
    try:
        yield
    finally:
        t.join()


def _allocation(ctx: RunContext) -> None:
    from corr_cad.export.files import write_csv, write_json
    from corr_cad.tolerance.allocation import allocate

    s = ctx.scene
    cfg = s.montecarlo
    kw = {
        "percentile": cfg["percentile"],
        "samples": cfg["allocation_samples"],
        "seed": cfg["seed"],
        "positions": min(cfg["positions"], 72),
        "load_share": s.solver.load_share,
        "executor": ctx.executor,
        "base_errors": scene_errors(ctx),
        "psi_contact_limit": psi_contact_limit(ctx),
        "datasheet": _datasheet_mc(s),
        "drive": _drive_mc(ctx),
    }
    d, m0 = s.design, s.load.input_torque
    rows = []
    from corr_cad.run.progress import Progress

    # Counted in Monte Carlo runs; the total is re-estimated as each search
    # narrows (allocate's own expected count, a typical count for the searches
    # still to come).
    searches = 2 * len(s.tolerances)
    bar = Progress(
        searches * ALLOCATION_EVALUATIONS,
        "      allocation",
        "Monte Carlo runs",
        expected=expected_seconds(ctx, "allocation"),
    )
    state = {"finished": 0, "left": searches}

    def tick(done: int, expected: int, rate: float) -> None:
        bar.total = state["finished"] + expected + (state["left"] - 1) * ALLOCATION_EVALUATIONS
        bar.update(1)

    def search(*args, **extra) -> dict:
        r = allocate(*args, progress=tick, **extra, **kw)
        state["finished"] += r["evaluations"]
        state["left"] -= 1
        return r

    for kind in s.tolerances:
        # Jointly: the other tolerances as given; alone: the others perfect.
        joint = search(d, m0, s.tolerances, s.checks, kind)
        dist = s.tolerances[kind].kind
        alone = search(d, m0, {}, s.checks, kind, distribution=dist)
        joint["tolerance_alone"] = alone["tolerance"]
        if "why_zero" in alone and alone["why_zero"] != joint.get("why_zero"):
            joint["why_zero_alone"] = alone["why_zero"]
        rows.append(joint)
    bar.close()

    def fmt(x):
        return "" if x is None else f"{x:.6g}"

    header = ["tolerance", "largest_symmetric_tolerance", "largest_if_others_perfect"]
    header += ["unit", "meaning", "fails_at", "evaluations"]
    table = (
        [r["kind"], fmt(r["tolerance"]), fmt(r["tolerance_alone"]), r["unit"], r["meaning"]]
        + [fmt(r["failing_at"]), str(r["evaluations"])]
        for r in rows
    )
    write_csv(ctx.out / "allocation.csv", header, table)
    doc = {"percentile": cfg["percentile"], "rows": rows}
    chain = samples_chain(s)
    if chain is not None:  # the key appears with the chain only (other files keep their bytes)
        doc["samples_chain"] = chain
    write_json(ctx.out / "allocation.json", doc)
    ctx.files.extend(["allocation.csv", "allocation.json"])
    ctx.manifest["allocation"] = rows
    for r in rows:
        t = "sigma " if r["distribution"] == "normal" else "+- "
        ctx.progress(
            f"      {r['kind']:14s} {t}{r['tolerance']:.4g} {r['unit']} with the others as given, "
            f"{t}{r['tolerance_alone']:.4g} {r['unit']} if the others were perfect"
        )
        for key in ("why_zero", "why_zero_alone"):
            if key in r:
                ctx.progress(f"      {r['kind']:14s} 0: {r[key]}")


def _sweeps(ctx: RunContext) -> None:
    from corr_cad.export import plots_tolerance
    from corr_cad.export.files import write_csv, write_json
    from corr_cad.tolerance.sweeps import (
        METRICS,
        PAPER_SWEEPS,
        comparison_rows,
        is_paper_design,
        run_sweeps,
        sweep_range,
    )

    s = ctx.scene
    ranges = {
        name: sweep_range(s.design, name, s.sweeps.get(name), scene_errors(ctx))
        for name in PAPER_SWEEPS
    }
    from corr_cad.run.progress import Progress

    for name, rng in ranges.items():  # a range the user gave with no valid point is an error
        given = s.sweeps.get(name)
        if given is not None and rng["swept"] is None:
            why = rng.get("clipped_low") or rng.get("clipped_high") or "outside the design space"
            raise SceneError(
                f"[sweeps] {name} = {given!r}: no point of this range is a valid design ({why})"
            )
    total = sum(s.sweeps["points"] for r in ranges.values() if r["swept"] is not None)
    bar = Progress(total, "      sweeps", "points", expected=expected_seconds(ctx, "sweeps"))
    results = run_sweeps(
        s.design,
        s.load.input_torque,
        s.sweeps["points"],
        s.sweeps["positions"],
        s.solver.load_share,
        executor=ctx.executor,
        ranges=ranges,
        progress=bar.update,
        drive=_sweep_model(ctx),
    )
    bar.close()
    header = ["value", "status", *METRICS, "loaded_rollers_min", "loaded_rollers_max"]
    header += ["range_source", "requested_min", "requested_max", "clipped_low", "clipped_high"]
    for name, pts in results.items():
        rng = ranges[name]
        limits = [rng["source"], *(f"{v:.6g}" for v in rng["requested"])]
        limits += [rng["clipped_low"] or "", rng["clipped_high"] or ""]
        write_csv(
            ctx.out / f"sweep_{name}.csv",
            header,
            (
                [f"{p['value']:.6g}", p["status"]]
                + [f"{p[k]:.6g}" if k in p else "" for k in header[2:-5]]
                + limits
                for p in pts
            ),
        )
        where = PAPER_SWEEPS[name][0]
        centre = getattr(s.design if where == "design" else scene_errors(ctx), name)
        plots_tolerance.sweep_png(
            name, pts, ctx.out / f"sweep_{name}.png", rng, s.design, s.load.input_torque, centre
        )
        ctx.files.extend([f"sweep_{name}.csv", f"sweep_{name}.png"])
        lim = "; ".join(
            f"{side} end clipped at {v:.5g} mm ({why})"
            for side, v, why in (
                ("low", (rng["swept"] or [None])[0], rng["clipped_low"]),
                ("high", (rng["swept"] or [None, None])[-1], rng["clipped_high"]),
            )
            if why and v is not None
        )
        ctx.progress(
            f"      sweep {name} {rng['requested'][0]:g}..{rng['requested'][1]:g} mm "
            f"({rng['source']}): {sum(p['status'] == 'ok' for p in pts)}/{len(pts)} points solved"
            + (f"; {lim}" if lim else "")
            + ("; no valid value in the range" if rng["swept"] is None else "")
        )
    out = {"ranges": ranges, "points": results}
    chain = samples_chain(s)
    if chain is not None:
        out["samples_chain"] = chain + (
            "; a design's sweep on that design's own influence tables"
            if s.solver.bodies == "elastic"
            else ""
        )
    if is_paper_design(s.design):
        rows = comparison_rows(results, ranges)
        cols = list(rows[0]) if rows else []
        write_csv(
            ctx.out / "sweeps_vs_paper.csv", cols, ([_cell(r[c]) for c in cols] for r in rows)
        )
        ctx.files.append("sweeps_vs_paper.csv")
        out["vs_paper"] = rows
    write_json(ctx.out / "sweeps.json", out)
    ctx.files.append("sweeps.json")
    ctx.manifest["sweeps"] = {
        n: {
            "range": ranges[n],
            "points": len(pts),
            "solved": sum(p["status"] == "ok" for p in pts),
        }
        for n, pts in results.items()
    }


def _cell(v) -> str:
    if v is None:
        return ""
    return f"{v:.6g}" if isinstance(v, float) else str(v)
