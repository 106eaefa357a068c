"""Sample work on a Dask cluster (``--executor dask``), every fault one line and exit 2.

The numerical core sees only ``submit`` and ``result`` (as with a process
pool); :class:`DaskExecutor` adds what a cluster can do to a run:

* **connect**: the address is probed first with a plain TCP connection and
  a read of the scheduler's greeting (a Dask scheduler speaks first), all
  within the connect time-out: a refused port, a host that does not answer,
  a listener that accepts but says nothing, or an HTTP server or proxy that
  answers are each named (Dask itself read an HTTP reply's first 8 bytes
  as a frame count, tried to allocate exabytes and said "MemoryError"; a
  silent listener held it 40 s);
* **no workers**: a scheduler with no worker is waited for at most the
  no-workers time-out, at the start and whenever every worker has left;
* **stall**: when no task has finished for the stall time-out (at least
  three times the estimated time of one task), the run stops;
* **lost workers**: the scheduler recomputes a lost worker's tasks itself;
  a task it gives up on (``KilledWorker``) or loses is resubmitted once, as
  the same function of the same arguments, so the results keep their bits.
  A second loss stops the run.

The time-outs are ``[dask]`` scene keys with command-line overrides
(``--dask-connect-timeout``, ``--dask-no-workers-timeout``,
``--dask-stall-timeout``).
"""

from __future__ import annotations

import socket
import struct
import sys
import time
from dataclasses import dataclass
from urllib.parse import urlsplit

from corr_cad.errors import CorrCadError

__all__ = ["DaskError", "DaskTimeouts", "timeouts_for", "probe", "connect", "DaskExecutor"]

DEFAULT_CONNECT_S = 5.0
DEFAULT_NO_WORKERS_S = 30.0
DEFAULT_STALL_S = 120.0
#: Seconds between two looks at the cluster while a result is awaited.
POLL_S = 1.0


class DaskError(CorrCadError, RuntimeError):
    """The Dask cluster could not run the work (no scheduler, no workers, a stall)."""


@dataclass(frozen=True)
class DaskTimeouts:
    connect: float = DEFAULT_CONNECT_S
    no_workers: float = DEFAULT_NO_WORKERS_S
    stall: float = DEFAULT_STALL_S
    #: What set each (for the messages): a flag, a scene key or "default".
    connect_from: str = "default"
    no_workers_from: str = "default"
    stall_from: str = "default"


def timeouts_for(scene, connect=None, no_workers=None, stall=None, task_seconds: float = 0.0):
    """The scene's ``[dask]`` with the command line's overrides; the stall time-out
    is at least three times ``task_seconds`` (the estimate of the longest task)."""
    given = getattr(scene, "dask", None) or {}

    def pick(flag, flag_name, key, default):
        if flag is not None:
            return float(flag), flag_name
        if given.get(key) is not None:
            return float(given[key]), f"[dask] {key}"
        return default, "default"

    c = pick(connect, "--dask-connect-timeout", "connect_timeout_s", DEFAULT_CONNECT_S)
    n = pick(no_workers, "--dask-no-workers-timeout", "no_workers_timeout_s", DEFAULT_NO_WORKERS_S)
    s = pick(stall, "--dask-stall-timeout", "stall_timeout_s", DEFAULT_STALL_S)
    if 3.0 * task_seconds > s[0]:
        s = (3.0 * task_seconds, f"3 x the estimated {task_seconds:.3g} s of one task")
    return DaskTimeouts(c[0], n[0], s[0], c[1], n[1], s[1])


#: Longest host name (RFC 1035: 253 characters, labels of at most 63).
MAX_HOST = 253


def check_address(address: str) -> None:
    """Refuse a ``--scheduler`` that is no address at all, before anything starts."""
    _where(address)


def _where(address: str) -> tuple[str, int] | None:
    """(host, port) of a TCP address (``tcp://host:port`` or ``host:port``), else None."""
    from corr_cad.bounds import show

    shown = show(address, 60)
    form = "give tcp://HOST:PORT, e.g. tcp://127.0.0.1:8786"
    if not address.isprintable():
        raise DaskError(f"--scheduler {shown}: holds control characters; {form}")
    text = address if "://" in address else f"tcp://{address}"
    try:
        parts = urlsplit(text)
        host, port = parts.hostname, parts.port
    except ValueError as exc:  # an unclosed '[', a bad IPv6 literal, a port out of range
        raise DaskError(f"--scheduler {shown}: not an address ({exc}); {form}") from None
    if host is not None and (
        len(host) > MAX_HOST or any(len(label) > 63 for label in host.split("."))
    ):
        raise DaskError(
            f"--scheduler {shown}: a host name of {len(host)} characters; at most "
            f"{MAX_HOST}, each dot-separated part at most 63; {form}"
        )
    if parts.scheme != "tcp":
        return None
    if not host or port is None:
        raise DaskError(f"--scheduler {shown}: not an address of the form tcp://HOST:PORT; {form}")
    return host, port


def probe(address: str, t: DaskTimeouts) -> None:
    """Refuse ``address`` unless a Dask scheduler greets there within ``t.connect`` s."""
    where = _where(address)
    if where is None:  # tls://, ucx://, inproc://: Dask's own connect (with its time-out)
        return
    setting = (
        f"{t.connect:g} s ({t.connect_from}; --dask-connect-timeout or [dask] connect_timeout_s)"
    )
    head = f"--scheduler {address}"
    deadline = time.monotonic() + t.connect
    try:
        sock = socket.create_connection(where, timeout=t.connect)
    except socket.gaierror as exc:
        raise DaskError(f"{head}: the host {where[0]!r} is not known ({exc.strerror})") from exc
    except ConnectionRefusedError as exc:
        raise DaskError(
            f"{head}: nothing listens there (connection refused); start a scheduler "
            "('dask scheduler') or give a running one's address"
        ) from exc
    except TimeoutError as exc:
        raise DaskError(
            f"{head}: no answer to the connection within {setting}: the host is unreachable "
            "or a firewall drops it"
        ) from exc
    except OSError as exc:
        raise DaskError(f"{head}: cannot connect ({exc.strerror or exc})") from exc
    with sock:
        sock.settimeout(max(0.05, deadline - time.monotonic()))
        got = b""
        try:
            while len(got) < 8:
                chunk = sock.recv(8 - len(got))
                if not chunk:
                    break
                got += chunk
        except TimeoutError:
            raise DaskError(
                f"{head}: a listener accepted the connection but sent nothing within {setting}; "
                "a Dask scheduler greets at once: this is not one (or it is stuck)"
            ) from None
        except OSError as exc:
            raise DaskError(f"{head}: the connection failed ({exc.strerror or exc})") from exc
    if len(got) < 8:
        raise DaskError(f"{head}: the listener closed the connection at once; not a Dask scheduler")
    if got.startswith(b"HTTP"):
        raise DaskError(
            f"{head}: an HTTP server or proxy answered ({got.decode('latin-1')}...), not a "
            "Dask scheduler; check the host and port (a scheduler's default port is 8786)"
        )
    frames = struct.unpack("<Q", got)[0]  # a Dask message starts with its frame count
    if not 1 <= frames <= 1024:
        raise DaskError(
            f"{head}: something answered that is not a Dask scheduler (its first bytes: {got!r})"
        )


def connect(address: str, t: DaskTimeouts, say=None) -> DaskExecutor:
    """A :class:`DaskExecutor` on the scheduler at ``address`` with at least one worker."""
    try:
        from dask.distributed import Client
    except ImportError as exc:
        raise DaskError("--executor dask needs the 'dask' extra: pip install -e '.[dask]'") from exc
    probe(address, t)
    _quiet_dask_logs()
    try:
        client = Client(address, timeout=t.connect)
    except Exception as exc:  # the probe passed: name what Dask said
        raise DaskError(
            f"--scheduler {address}: the Dask handshake failed within {t.connect:g} s "
            f"({type(exc).__name__}: {exc})"
        ) from exc
    ex = DaskExecutor(client, address, t)
    try:
        ex.wait_for_workers(say)
    except BaseException:
        ex.close()
        raise
    return ex


def _quiet_dask_logs() -> None:
    """Keep distributed's and asyncio's log lines off the user's terminal: a worker
    lost while its result is gathered logs "Couldn't gather ... rescheduling" and,
    when the run then stops, "Task exception was never retrieved" with a traceback
    (AllExit). Every fault is reported as one ``DaskError`` line instead."""
    import logging

    # distributed's own logging config gives some child loggers their own level
    # (distributed.client: warning), so each is set, not only the parent.
    names = [n for n in logging.root.manager.loggerDict if n.split(".")[0] == "distributed"]
    for name in ("distributed", "distributed.client", "asyncio", *names):
        logging.getLogger(name).setLevel(logging.CRITICAL)


class DaskExecutor:
    """``submit``/``result`` on a Dask ``Client`` with time-outs and one resubmission."""

    def __init__(self, client, address: str, t: DaskTimeouts) -> None:
        self.client, self.address, self.t = client, address, t
        self.submitted = self.finished = 0
        self.resubmitted = 0
        self._last_done = time.monotonic()
        self._last_look = 0.0
        self._alone_since: float | None = None

    @property
    def scheduler_info(self):  # marks a Dask executor (pipeline._executor_kind)
        return self.client.scheduler_info

    def close(self) -> None:
        try:
            self.client.close(timeout=self.t.connect)
        except Exception:  # closing a client whose scheduler is gone: nothing to keep
            pass

    def workers(self) -> int:
        return len(self.client.nthreads(callback_timeout=self.t.connect))

    def wait_for_workers(self, say=None) -> None:
        if self.workers():
            return
        if say is not None:
            say(
                f"waiting up to {self.t.no_workers:g} s for a Dask worker at {self.address} "
                f"(start one: dask worker {self.address})"
            )
        try:
            self.client.wait_for_workers(1, timeout=self.t.no_workers)
        except Exception as exc:  # distributed's TimeoutError
            raise DaskError(
                f"--scheduler {self.address}: the scheduler has no workers (waited "
                f"{self.t.no_workers:g} s, {self.t.no_workers_from}; --dask-no-workers-timeout "
                f"S or [dask] no_workers_timeout_s waits longer); start one: "
                f"dask worker {self.address}"
            ) from exc

    def submit(self, fn, *args):
        if self.submitted == self.finished:  # a new batch: the stall clock starts now
            self._last_done = time.monotonic()
        self.submitted += 1
        return _Task(self, fn, args, self.client.submit(fn, *args))

    def _done(self) -> None:
        self.finished += 1
        self._last_done = time.monotonic()

    def _counts(self) -> str:
        return f"{self.finished} of {self.submitted} tasks done"

    def _look(self) -> None:
        """Between polls: the scheduler, its workers and the time since a task finished."""
        now = time.monotonic()
        if now - self._last_look >= POLL_S:
            self._last_look = now
            try:
                n = self.workers()
            except Exception as exc:
                raise DaskError(
                    f"Dask: lost the scheduler at {self.address} ({type(exc).__name__}: "
                    f"{exc}); {self._counts()}"
                ) from exc
            if n:
                self._alone_since = None
            elif self._alone_since is None:
                self._alone_since = now
            elif now - self._alone_since > self.t.no_workers:
                raise DaskError(
                    f"Dask: every worker left the scheduler at {self.address} (killed, out of "
                    f"memory?) and none came back within {self.t.no_workers:g} s "
                    f"({self.t.no_workers_from}; --dask-no-workers-timeout S waits longer); "
                    f"{self._counts()}"
                )
        if now - self._last_done > self.t.stall:
            raise DaskError(
                f"Dask: no task finished for {self.t.stall:.0f} s ({self.t.stall_from}; "
                f"--dask-stall-timeout or [dask] stall_timeout_s); {self._counts()} on "
                f"{self.address}; a worker may be stuck or swapping"
            )


class _Task:
    """One submitted task: its result awaited in short polls, resubmitted once if lost."""

    def __init__(self, ex: DaskExecutor, fn, args, future) -> None:
        self.ex, self.fn, self.args, self.future = ex, fn, args, future
        self.retried = False
        self._value = None
        self._has = False

    def done(self) -> bool:
        return self._has or self.future.done()

    def result(self):
        from distributed import KilledWorker
        from distributed.client import FutureCancelledError

        if self._has:
            return self._value
        while True:
            try:
                value = self.future.result(timeout=POLL_S)
            except TimeoutError:
                self.ex._look()
                continue
            except (KilledWorker, FutureCancelledError) as exc:
                self.ex._last_look = 0.0
                self.ex._look()  # a lost scheduler is named as such, not as a lost task
                cause = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
                if self.retried:
                    raise DaskError(
                        f"Dask: a task was lost twice with its worker ({cause}); "
                        f"{self.ex._counts()}; the workers may run out of memory"
                    ) from exc
                self.retried = True
                self.ex.resubmitted += 1
                print(
                    f"corr-cad: warning: Dask: a task was lost with its worker ({cause}); "
                    "resubmitted once",
                    file=sys.stderr,
                    flush=True,
                )
                self.future = self.ex.client.submit(self.fn, *self.args, pure=False)
                continue
            self.ex._done()
            self._value, self._has = value, True
            self.future = None
            return value
