"""Command line: ``corr-cad run SCENE``, ``corr-cad new SCENE``, ``corr-cad schema``.

Exit codes: 0 success; 1 a ``[checks]`` limit (or the Monte Carlo gate)
failed, or an exported file misses its tolerance; 2 bad input, a refused
design, an unusable output folder or a full disk (one line on stderr, no
traceback, previous outputs left as they were); 3 an internal error, a bug
(one line naming the stage and what was lost; ``CORR_CAD_DEBUG=1`` adds the
traceback); 130 SIGINT, 143 SIGTERM.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import threading
from pathlib import Path
from typing import NoReturn

from corr_cad._version import __version__
from corr_cad.errors import CorrCadError
from corr_cad.run import cli_messages as msg
from corr_cad.run.pools import _start_pool, _warm_modules, _worker_init  # noqa: F401

__all__ = ["main"]


def _refuse_empty(args: argparse.Namespace) -> None:
    from corr_cad.errors import OutputError

    for attr, flag in (("out", "--out"), ("scene", "SCENE")):
        if getattr(args, attr, None) == "":
            raise OutputError(
                f"{flag} '': an empty path (an unset variable?); give one, e.g. "
                + ("--out outputs/NAME" if attr == "out" else "corr-cad new my_scene.toml")
            )


class _OneLineParser(argparse.ArgumentParser):
    """argparse, but a flag error is one line (no usage block) and exit 2."""

    def error(self, message: str) -> NoReturn:
        hint = f"; '{self.prog} --help' lists the flags"
        self.exit(2, msg.one_line(f"corr-cad: error: {self.prog}: {message}{hint}", 1000) + "\n")


def _parser() -> argparse.ArgumentParser:
    p = _OneLineParser(
        prog="corr-cad",
        description=(
            "Profiles, machining files and mesh forces for compound oscillatory roller "
            "reducers. Units: mm, N, N*mm, MPa."
        ),
    )
    p.add_argument("--version", action="version", version=f"corr-cad {__version__}")
    sub = p.add_subparsers(
        dest="command", required=True, metavar="COMMAND", parser_class=_OneLineParser
    )
    run = sub.add_parser("run", help="build what a scene file asks for")
    run.add_argument("scene", type=Path, help="scene file (TOML)")
    run.add_argument(
        "--out", type=msg.out_arg, default=None, help="output folder (default outputs/<scene name>)"
    )
    run.add_argument("--quiet", action="store_true", help="print nothing but errors")
    run.add_argument(
        "--executor",
        choices=("process", "serial", "dask"),
        default="process",
        help="where Monte Carlo and allocation samples run (default: a process pool)",
    )
    run.add_argument(
        "--scheduler", default=None, help="Dask scheduler address (with --executor dask)"
    )
    run.add_argument(
        "--workers", type=int, default=None, help="process pool size (default: all usable cores)"
    )
    budget = run.add_argument_group("budget (overrides the scene's [budget])")
    budget.add_argument(
        "--max-memory", type=float, metavar="GB", help="memory the run may plan to use (3)"
    )
    budget.add_argument(
        "--max-output", type=float, metavar="GB", help="total size of the files written (1)"
    )
    budget.add_argument(
        "--warn-time", type=float, metavar="S", help="warn when the run would take longer (60)"
    )
    dask = run.add_argument_group("Dask time-outs (override the scene's [dask])")
    dask.add_argument("--dask-connect-timeout", type=float, metavar="S", help="default 5")
    dask.add_argument("--dask-no-workers-timeout", type=float, metavar="S", help="default 30")
    dask.add_argument("--dask-stall-timeout", type=float, metavar="S", help="default 120")
    help_ = 'run only a scene\'s [sizing] design search (formats = ["sizing"])'
    sub.add_parser("size", parents=[run], add_help=False, help=help_)
    bench = sub.add_parser("bench", help="measure what accuracy costs in time (tables, CSV, PNG)")
    bench.add_argument(
        "--out", type=msg.out_arg, default=Path("outputs") / "bench", help="default outputs/bench"
    )
    bench.add_argument(
        "--study",
        action="append",
        choices=(
            "profile",
            "solids",
            "solver",
            "speed",
            "montecarlo",
            "throughput",
            "kernel",
            "interference",
            "coldstart",
            "datasheet",
            "friction",
            "resources",
            "drive",
            "progress",
            "compound",
            "bodies",
            "sizing",
        ),
        help="run only this study (repeatable); default all",
    )
    bench.add_argument("--quick", action="store_true", help="fewer settings and repeats")
    bench.add_argument(
        "--workers",
        type=msg.worker_list,
        metavar="N,N,...",
        help="worker counts of the montecarlo study's sweep (default 1,2,4,... up to the cores)",
    )
    schema = sub.add_parser(
        "schema", help="print the JSON Schema of scene files (for TOML editors)"
    )
    schema.add_argument(
        "--out",
        type=msg.out_arg,
        default=None,
        help="write it to this new file instead of printing (refuses to overwrite)",
    )
    sub.add_parser("warm-up", help="compile the numerical kernels now (once after install)")
    new = sub.add_parser("new", help="write a commented scene template")
    new.add_argument("scene", type=msg.out_arg, help="file to create (refuses to overwrite)")
    return p


def _check_workers(args: argparse.Namespace) -> None:
    import math

    from corr_cad.errors import SceneError
    from corr_cad.run.scene.scene_schema import SCHEMA, key_range

    cores = os.cpu_count() or 1
    if args.workers is not None and not 1 <= args.workers <= cores:
        raise SceneError(
            f"--workers {args.workers}: allowed range is 1..{cores} (the number of cores), "
            f"e.g. --workers {cores}"
        )
    # Each flag has the range of the scene key it overrides.
    for flag, section, key in _FLAG_KEYS:
        v = _flag(args, flag)
        spec = SCHEMA[section][key]
        if v is not None and not (math.isfinite(v) and spec.low < v <= spec.high):
            raise SceneError(
                f"{flag} {v:g}: allowed range is {key_range(spec)} (as [{section}] {key}), "
                f"e.g. {flag} {spec.works()}"
            )


#: Command-line flags and the scene keys they override.
_FLAG_KEYS = (
    ("--max-memory", "budget", "memory_gb"),
    ("--max-output", "budget", "output_gb"),
    ("--warn-time", "budget", "time_warning_s"),
    ("--dask-connect-timeout", "dask", "connect_timeout_s"),
    ("--dask-no-workers-timeout", "dask", "no_workers_timeout_s"),
    ("--dask-stall-timeout", "dask", "stall_timeout_s"),
)


def _run(args: argparse.Namespace, state: dict) -> int:
    from corr_cad.run.budget.resources import (
        budget_for,
        check_disk,
        check_scene,
        default_workers,
        time_warning,
    )
    from corr_cad.run.folder.outputs import StagingDir, check_out_dir, safe_folder_name
    from corr_cad.run.pipeline import run_scene
    from corr_cad.run.scene.scene import load_scene

    _check_workers(args)
    if args.executor == "dask" and args.scheduler:
        from corr_cad.run.dask_exec import check_address

        check_address(args.scheduler)  # a malformed one is refused before anything starts
    if args.command == "size":
        from corr_cad.run.scene.scene_sizing import load_sizing_scene as load_scene
    scene = load_scene(args.scene)
    # Refused here, with one line, before any folder or worker exists.
    budget = budget_for(scene, args.max_memory, args.max_output, args.warn_time)
    workers = 1 if args.executor == "serial" else args.workers or default_workers()
    est = check_scene(scene, workers, budget, args.executor)
    slow = time_warning(scene, est, budget, args.executor)
    if args.quiet:
        from corr_cad.run import progress

        progress.set_enabled(False)  # main() restores it when the call ends
    out = args.out if args.out is not None else Path("outputs") / safe_folder_name(scene.name)
    check_out_dir(out)  # refuse before anything is created or started
    check_disk(est, out)  # the files must fit where they go
    say = (lambda m: None) if args.quiet else (lambda m: print(m, flush=True))
    say(f"corr-cad {__version__}: scene {scene.name!r} -> {out}")
    from corr_cad.run.warmup import compile_ahead

    compile_ahead(scene, say)  # before any pool worker starts: they load what it compiles
    staging = StagingDir(out, formats=scene.formats)
    state["staging"] = staging
    concurrent = _concurrent_stages(args, scene)
    if concurrent:
        from corr_cad.run.stages.concurrent import make_ahead

        make_ahead(scene)  # before the pool forks: its workers inherit what it makes
    task_s = max((c.task_seconds for c in est.stages.values()), default=0.0)
    from corr_cad.run.pipeline import scene_plan
    from corr_cad.run.stages.plot_workers import plot_pool

    cores = 0 if args.executor != "process" else workers  # the usable cores, as estimated
    from corr_cad.run.stages.concurrent import kill_pool

    plots = plot_pool(_start_pool, kill_pool, scene_plan(scene), cores)
    with _executor(args, scene, concurrent, task_s) as executor, plots as plotter, staging as stage:
        # Printed with --quiet too (the user must know), once the run is
        # accepted: a refused run prints only its one error line.
        for warning in scene.warnings + _executor_warnings(args, scene) + ((slow,) if slow else ()):
            print(f"corr-cad: warning: {warning}", file=sys.stderr)
        if scene.formats_left_out:
            why = "; ".join(f"{f} ({w})" for f, w in scene.formats_left_out)
            print(f'corr-cad: note: formats = ["all"] leaves out {why}', file=sys.stderr)
        manifest = run_scene(
            scene,
            stage,
            progress=say,
            executor=executor,
            concurrent_stages=concurrent,
            budget=budget,
            estimate=est,
            plotter=plotter,
        )
    from corr_cad.run.console import failed_checks, summary_lines

    if not args.quiet:
        print("\n".join(summary_lines(manifest, out)), flush=True)
    status = 0
    for acc in manifest.get("accuracy", {}).values():
        if not acc.get("within_tolerance", True):
            print(
                f"corr-cad: {acc['file']}: {acc['layer']} measured max deviation "
                f"{acc['max_deviation_mm']:.4g} mm exceeds the tolerance "
                f"{acc['tolerance_mm']:g} mm "
                f"({acc['representation']}, {acc['vertex_count']} vertices)",
                file=sys.stderr,
            )
            status = 1
    failed = failed_checks(manifest)
    if failed:
        print(f"corr-cad: check failed: {'; '.join(failed)}", file=sys.stderr)
    bad = manifest.get("inspection", {}).get("failed")
    if bad:
        print(f"corr-cad: inspection failed: {'; '.join(bad)}", file=sys.stderr)
    asm = [
        *manifest.get("assembly", {}).get("failed", []),
        *manifest.get("modification_design", {}).get("failed", []),
        *manifest.get("sizing", {}).get("failed", []),
    ]
    if asm:
        print(f"corr-cad: {'; '.join(asm)}", file=sys.stderr)
    if failed or bad or asm:
        return 1
    return status


def _executor_warnings(args: argparse.Namespace, scene) -> tuple[str, ...]:
    """``[dask]`` and the Dask flags do nothing without ``--executor dask``."""
    if args.executor == "dask":
        return ()
    given = [f"[dask] {k}" for k, v in scene.dask.items() if v is not None]
    given += [f for f, sec, _ in _FLAG_KEYS if sec == "dask" and _flag(args, f) is not None]
    given += ["--scheduler"] if args.scheduler else []
    why = f"--executor is {args.executor}, not dask"
    return tuple(f"{what} has no effect in this run: {why}" for what in given)


def _flag(args: argparse.Namespace, flag: str):
    return getattr(args, flag.lstrip("-").replace("-", "_"))


def _concurrent_stages(args: argparse.Namespace, scene) -> bool:
    """Run the STEP export in a pool worker beside the other stages?

    With the process executor and two or more workers (``--workers``, default the
    usable cores, ``default_workers``), when the scene has other work to overlap it
    with (:mod:`corr_cad.run.stages.concurrent`).
    """
    from corr_cad.run.budget.resources import default_workers
    from corr_cad.run.pipeline import scene_plan
    from corr_cad.run.stages.concurrent import worker_stages

    if args.executor != "process" or (args.workers or default_workers()) < 2:
        return False
    return bool(worker_stages(scene_plan(scene)))


@contextlib.contextmanager
def _executor(
    args: argparse.Namespace, scene, concurrent_stages: bool = False, task_seconds: float = 0.0
):
    """The executor for sample work and worker stages; only started (or contacted) when needed.

    Dask: :mod:`corr_cad.run.dask_exec` (probed, time-outs, lost tasks
    resubmitted once); ``task_seconds``, the estimate of the longest task,
    sets a floor under the stall time-out.
    """
    from corr_cad.errors import SceneError
    from corr_cad.run.budget.costs_montecarlo import pool_pays

    needs = {"montecarlo", "allocation", "sweeps", "sizing"} & set(scene.formats)
    if args.executor == "process" and "montecarlo" in needs and not pool_pays(scene):
        needs.discard("montecarlo")  # its samples run in the main process
    if args.executor == "dask":
        if not args.scheduler:
            raise SceneError("--executor dask needs --scheduler ADDRESS (e.g. tcp://host:8786)")
        if not needs:
            yield None
            return
        from corr_cad.run.dask_exec import connect, timeouts_for

        t = timeouts_for(
            scene,
            args.dask_connect_timeout,
            args.dask_no_workers_timeout,
            args.dask_stall_timeout,
            task_seconds,
        )
        say = None if args.quiet else (lambda m: print(m, flush=True))
        client = connect(args.scheduler, t, say)
        try:
            yield client
        finally:
            client.close()
        return
    if args.executor == "serial" or not (needs or concurrent_stages):
        yield None
        return
    from concurrent.futures import ProcessPoolExecutor

    from corr_cad.run.budget.resources import default_workers
    from corr_cad.run.stages.concurrent import kill_pool

    # The usable cores (the affinity: taskset, a container's cpuset), as the estimate
    # counts them; ProcessPoolExecutor's own default is os.cpu_count().
    workers = args.workers or default_workers()
    pool = _start_pool(ProcessPoolExecutor, workers, _warm_modules(scene))
    try:
        yield pool
    except BaseException:
        kill_pool(pool)
        raise
    pool.shutdown(wait=True)


def _create(path: Path, text: str) -> None:
    """Write a new file; one that exists (or appears meanwhile) is never replaced."""
    from corr_cad.bounds import show
    from corr_cad.errors import SceneError
    from corr_cad.export.files import write_new_text

    shown = show(str(path), 120)
    if os.path.lexists(path):
        raise SceneError(f"{shown} exists; choose another name (it is never overwritten)")
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        write_new_text(path, text)
    except FileExistsError as exc:
        raise SceneError(f"{shown} exists; choose another name (it is never overwritten)") from exc
    print(f"wrote {path}")


def _new(args: argparse.Namespace) -> int:
    from corr_cad.run.scene.scene import template_text

    _create(args.scene, template_text())
    return 0


def _on_signal(signum, frame) -> None:
    """SIGINT and SIGTERM: recorded (:mod:`corr_cad.run.interrupts`), then raised."""
    from corr_cad.run import interrupts

    interrupts.mark(signum)
    interrupts.check()


def _schema(args: argparse.Namespace) -> int:
    from corr_cad.run.scene.schema_json import schema_text

    text = schema_text()
    if args.out is None:
        sys.stdout.write(text)
        return 0
    _create(args.out, text)  # the rule of 'corr-cad new': never overwrite
    return 0


#: Longest error or warning line printed (a message quoting a file is cut).
def _dispatch(args: argparse.Namespace, state: dict) -> int:
    _refuse_empty(args)
    if args.command in ("run", "size"):
        return _run(args, state)
    if args.command == "bench":
        from corr_cad.run.bench.bench import STUDIES, run

        run(args.out, args.study or list(STUDIES), quick=args.quick, workers=args.workers)
        print(f"wrote the benchmark tables and plots to {args.out}")
        return 0
    if args.command == "schema":
        return _schema(args)
    if args.command == "warm-up":
        from corr_cad.run.warmup import command

        return command()
    return _new(args)


#: The youngest generation's collection threshold while a command runs (Python's 700 spent
#: 0.7 s in 1,042 collections on the compound with every format, this one 0.25 s).
GC_THRESHOLD0 = 10_000


def main(argv: list[str] | None = None) -> int:
    import gc
    import signal

    import corr_cad._startup as _startup
    from corr_cad.run import interrupts, progress
    from corr_cad.run.console import ClosedPipeSafe

    interrupts.clear()
    handlers: dict = {}
    hook, stdout, shown = sys.unraisablehook, sys.stdout, progress.enabled()
    threshold = gc.get_threshold()
    backend = os.environ.get("MPLBACKEND")
    # Every picture is drawn by Agg: a backend the user set for other programs (or one
    # matplotlib does not know, which fails its import) is not this command's.
    os.environ["MPLBACKEND"] = "agg"
    try:
        gc.set_threshold(max(threshold[0], GC_THRESHOLD0), *threshold[1:])
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                now = signal.getsignal(sig)
                # Ctrl-C: ours, unless a caller (a notebook, a test) installed its own.
                if (
                    sig == signal.SIGTERM
                    or now is signal.default_int_handler
                    or _startup.is_guard(now)
                ):
                    handlers[sig] = signal.signal(sig, _on_signal)
        sys.unraisablehook = interrupts.unraisable_hook
        sys.stdout = ClosedPipeSafe(stdout)
        return _main(argv)
    except KeyboardInterrupt as exc:  # before or after _main's own handling
        return msg.interrupted(exc, {})
    finally:  # called in-process (tests, notebooks): leave nothing behind
        interrupts.clear()
        sys.unraisablehook = hook
        sys.stdout = stdout
        progress.set_enabled(shown)  # a --quiet call leaves the next one its progress
        gc.set_threshold(*threshold)
        if backend is None:
            os.environ.pop("MPLBACKEND", None)
        else:
            os.environ["MPLBACKEND"] = backend
        for sig, previous in handlers.items():
            # The command's start-up guard says "previous outputs left": wrong once the
            # run is over, so a Ctrl-C while the process exits is ignored instead.
            signal.signal(sig, signal.SIG_IGN if _startup.is_guard(previous) else previous)


def _main(argv: list[str] | None) -> int:
    import warnings
    from concurrent.futures import BrokenExecutor

    from corr_cad.run import interrupts

    state: dict = {}
    try:
        args = _parser().parse_args(argv)
        from corr_cad.run.budget.memory import keep_freed_memory

        keep_freed_memory()  # fresh pages fault at every new array otherwise: see memory.py
        with warnings.catch_warnings(record=True) as caught:
            code = _dispatch(args, state)
        interrupts.check()  # an interrupt swallowed on the way (a GC callback) still ends it
        msg.show_warnings(caught)
        return code
    except CorrCadError as exc:
        msg.error(str(exc))
        return 2
    except BrokenExecutor:
        # A pool worker died under us (killed, out of memory, a crash in a
        # native library); the staging folder is already gone.
        msg.error(
            "a worker process died (killed, or out of memory?); "
            "previous outputs left as they were; --executor serial runs without workers"
        )
        return 2
    except OSError as exc:
        where = f"{msg.shown_path(exc.filename)}: " if exc.filename else ""
        msg.error(f"{where}{exc.strerror or exc}; previous outputs left as they were")
        return 2
    except Exception as exc:  # a bug: one line that says what was lost, never exit 1
        msg.internal_error(exc, args, state)
        return msg.INTERNAL_ERROR
    except KeyboardInterrupt as exc:
        return msg.interrupted(exc, state)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
