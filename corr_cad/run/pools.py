"""Process pools of ``corr-cad run``: a worker's start (it dies with the main process,
leaves Ctrl-C to it, imports ahead what its tasks need) and the pool forked with the
signals held."""

from __future__ import annotations

import os
import sys
import threading
from pathlib import Path

from corr_cad.run import cli_messages as msg

__all__ = ["WARM_MODULES"]

#: numba and the compiled kernels' modules, which a pool worker of a Monte
#: Carlo on the compiled kernel imports at its first task: imported when the
#: worker starts instead, while the main process runs the stages before.
WARM_MODULES = ("corr_cad.mechanics.row.mc_kernel", "corr_cad.mechanics.row.mc_windup_kernel")


def _warm_modules(scene) -> tuple[str, ...]:
    """What the pool's workers import ahead for this scene (:data:`WARM_MODULES`, or none).

    The Monte Carlo's own modules are imported here, in the main process, which
    needs them too: the workers it forks next have them without importing. The
    kernels only where the samples use them (the datasheet metrics, or
    ``KERNEL_MIN_WORK`` samples x positions); elsewhere numba would only take
    the workers' memory.
    """
    if not {"montecarlo", "allocation"} & set(scene.formats):
        return ()
    import corr_cad.tolerance.mc_datasheet  # noqa: F401
    from corr_cad.run.scene.scene_montecarlo import wants_datasheet_metrics
    from corr_cad.tolerance.montecarlo import KERNEL_MIN_WORK

    mc = scene.montecarlo
    work = mc["samples"] * mc["positions"] >= KERNEL_MIN_WORK
    if "montecarlo" in scene.formats and not scene.solver.drive:
        if work or wants_datasheet_metrics(scene):
            return WARM_MODULES
    return ()


def _worker_init(parent_pid: int, warm: tuple[str, ...] = ()) -> None:
    """Process-pool worker start: die with the main process, leave Ctrl-C to it.

    On Linux the kernel sends SIGKILL when the parent dies (PR_SET_PDEATHSIG);
    a daemon thread polling ``os.getppid()`` covers other platforms and the
    instant before the ``prctl`` call. Then the modules ``warm`` are imported
    (:data:`WARM_MODULES`, or a plot worker's plot modules), which the tasks
    would otherwise import, and with the kernels numba's CPU target is built
    (:func:`~corr_cad.mechanics.row.mc_kernel.load_target`). A module that
    fails to import is left to the task, whose error the stage reports.
    """
    import signal
    import threading
    import time
    import warnings

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    # The parent forks with both blocked (_start_pool); Ctrl-C stays the parent's.
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})

    def one_line(message, category, filename, lineno, file=None, line=None) -> None:
        where = f"{Path(filename).name}:{lineno}"
        text = f"corr-cad: warning: {category.__name__} in {where}: {message}"
        print(msg.one_line(text), file=sys.stderr)

    warnings.showwarning = one_line  # never a raw two-line warning from a worker
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent_pid:
        os._exit(1)

    def watch() -> None:
        while True:
            if os.getppid() != parent_pid:
                os._exit(1)
            time.sleep(0.2)

    threading.Thread(target=watch, name="corr-cad-parent-watch", daemon=True).start()
    import importlib

    for name in warm:
        try:
            importlib.import_module(name)
        except Exception:  # noqa: BLE001 - raised again by the task that needs it
            # An error here would break the pool ("a worker process died") after a
            # traceback: the task's own import raises it in its stage, as serially.
            return
    if "corr_cad.mechanics.row.mc_kernel" in warm:
        from corr_cad.mechanics.row.mc_kernel import load_target

        load_target()


def _start_pool(pool_type, workers: int | None, warm: tuple[str, ...] = ()):
    """A process pool whose workers are forked now, with SIGINT and SIGTERM held.

    A signal that arrives while the pool forks would run its handler inside
    an at-fork hook (logging registers some), where the KeyboardInterrupt is
    printed as "Exception ignored" and lost: the run went on and exited 0.
    Held, it is delivered when the forks are done, in the run proper. (The
    pool forks every worker at its first task: submitting one now does it
    here.)
    """
    import signal

    held = {signal.SIGINT, signal.SIGTERM}
    pool = pool_type(max_workers=workers, initializer=_worker_init, initargs=(os.getpid(), warm))
    if threading.current_thread() is not threading.main_thread():
        return pool
    old = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        pool.submit(os.getpid)
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
    return pool
