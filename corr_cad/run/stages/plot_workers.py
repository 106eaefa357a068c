"""Draw a stage's PNGs in a forked worker that imported matplotlib while the run computed.

Importing matplotlib and the plot modules takes about 0.3-0.5 s of CPU and drawing a
figure 0.3-0.45 s; a run that only computes before its figures (a Monte Carlo, the
datasheet) otherwise pays both in its last stage, one after the other, on one core.
With the process executor on a machine of two cores or more the CLI forks one or two
plot workers (:func:`plot_pool`) before the stages run: each imports the plot modules
of the planned stages (:data:`PLOT_MODULES`) at its start, beside the main process's
computation, and then draws what a stage hands it (:func:`draw`) while the main process
writes the stage's other files or draws another figure. The main process never imports
matplotlib for these stages.

What stays as in a serial run:

* the bytes of every PNG: the worker runs the same plot function on the same values
  (pickled), with the same matplotlib, forked from the same process;
* errors: a plot function's error is raised in the main process, in the stage, where
  the CLI reports it as it would have;
* warnings: a plot function's warnings are raised again in the main process when its
  result is taken, where the CLI collects them (shown once the run has succeeded, never
  printed by the worker);
* interruption: the workers die with the main process (``pools._worker_init``), and a
  failed run kills them before its staging folder is removed
  (:func:`~corr_cad.run.pipeline.run_scene`, :func:`plot_pool`).

The plot workers are started only for plans whose stages draw nothing else in the main
process (:data:`QUIET_STAGES`): elsewhere the main process imports matplotlib anyway and
the workers' imports would be CPU spent twice. ``--executor serial``, ``--workers 1``, Dask
and :func:`~corr_cad.run.pipeline.run_scene` called from Python draw in the main process.
"""

from __future__ import annotations

import contextlib
import importlib
import warnings

__all__ = ["PLOT_MODULES", "QUIET_STAGES", "plot_plan", "plot_pool", "draw", "wait"]

#: The plot modules each stage draws with in a plot worker (imported at the worker's start).
PLOT_MODULES = {
    "montecarlo": ("corr_cad.export.plots_tolerance",),
    "datasheet_files": ("corr_cad.export.datasheet_plots",),
}
#: Stages that draw nothing in the main process: a plan of these only (and at least one
#: stage of :data:`PLOT_MODULES`) starts the plot workers.
QUIET_STAGES = frozenset(
    {"undercut", "profiles", "forces", "checks", "datasheet", "allocation", *PLOT_MODULES}
)
#: Plot workers a stage can use: the datasheet's two figures side by side.
_WORKERS = {"montecarlo": 1, "datasheet_files": 2}


def plot_plan(stages: list[str], cores: int) -> tuple[int, tuple[str, ...]]:
    """How many plot workers a run of ``stages`` starts, and the modules they import.

    ``cores``: the cores the run may use (``--workers``, by default all). The plot
    workers and the main process never outnumber them: on two cores one worker draws
    the datasheet's figures one after the other, on three or more two draw them side
    by side.

    >>> plot_plan(["undercut", "montecarlo"], 2)
    (1, ('corr_cad.export.plots_tolerance',))
    >>> plot_plan(["undercut", "datasheet", "datasheet_files"], 2)
    (1, ('corr_cad.export.datasheet_plots',))
    >>> plot_plan(["undercut", "datasheet", "datasheet_files"], 4)
    (2, ('corr_cad.export.datasheet_plots',))
    >>> plot_plan(["undercut", "profiles", "preview_png", "montecarlo"], 2)  # matplotlib here too
    (0, ())
    >>> plot_plan(["undercut", "montecarlo"], 1)
    (0, ())
    """
    drawing = [s for s in stages if s in PLOT_MODULES]
    if cores < 2 or not drawing or not set(stages) <= QUIET_STAGES:
        return 0, ()
    n = min(max(_WORKERS[s] for s in drawing), cores - 1)
    return n, tuple(m for s in drawing for m in PLOT_MODULES[s])


@contextlib.contextmanager
def plot_pool(start, kill, stages: list[str], cores: int):
    """The plot workers of a run (None where :func:`plot_plan` starts none).

    ``start(pool_type, workers, modules)``: the CLI's pool start (forked now, signals
    held, each worker importing ``modules``); ``kill(pool)``: kills them, as a failed
    run does."""
    n, modules = plot_plan(stages, cores)
    if not n:
        yield None
        return
    from concurrent.futures import ProcessPoolExecutor

    pool = start(ProcessPoolExecutor, n, modules)
    try:
        yield pool
    except BaseException:
        kill(pool)
        raise
    pool.shutdown(wait=True)


def _draw(module: str, function: str, args: tuple, kwargs: dict):
    """Call ``module.function(*args, **kwargs)`` (in a plot worker, or here)."""
    return getattr(importlib.import_module(module), function)(*args, **kwargs)


def _draw_caught(module: str, function: str, args: tuple, kwargs: dict):
    """In a plot worker: the drawing's return value and its warnings (message, category,
    file, line), raised again in the main process (:class:`_Remote`)."""
    with warnings.catch_warnings(record=True) as caught:
        value = _draw(module, function, args, kwargs)
    return value, [(str(w.message), w.category, w.filename, w.lineno) for w in caught]


class _Remote:
    """A figure a plot worker draws: :meth:`result` waits for it, raises its error or
    its warnings here."""

    def __init__(self, future) -> None:
        self.future = future

    def result(self):
        value, caught = self.future.result()
        for message, category, filename, lineno in caught:
            warnings.warn_explicit(message, category, filename, lineno)
        return value


class _Drawn:
    """A figure drawn in the main process (the result of a future that is done)."""

    def __init__(self, value) -> None:
        self.value = value

    def result(self):
        return self.value


def draw(pool, module: str, function: str, *args, **kwargs):
    """Draw ``module.function(*args, **kwargs)`` on the plot workers ``pool`` (or here,
    now, where it is None); returns what :meth:`result` gives (the drawing's return
    value, or its error raised)."""
    if pool is None:
        return _Drawn(_draw(module, function, args, kwargs))
    return _Remote(pool.submit(_draw_caught, module, function, args, kwargs))


def wait(drawings) -> None:
    """Wait for every drawing; the first error is raised once all are done (no worker
    writes into the folder after its stage)."""
    error = None
    for d in drawings:
        try:
            d.result()
        except Exception as exc:  # noqa: BLE001 - raised below, once all are done
            error = error or exc
    if error is not None:
        raise error
