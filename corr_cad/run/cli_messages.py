"""The command's lines on stderr: one line per error, warning, interrupt or bug.

Every refusal and failure of ``corr-cad`` is one line, never cut: what it
quotes of the user's values or of a library's message is bounded where it is
quoted (:func:`corr_cad.bounds.show`); numerical warnings from libraries are
shown as notes of at most :data:`MAX_LINE` characters;
an interrupt and an unexpected exception say what happened to the output
folder (docs/output-folder.md).
"""

from __future__ import annotations

import argparse
import os
import re
import sys
from pathlib import Path

__all__ = [
    "out_arg",
    "worker_list",
    "INTERNAL_ERROR",
    "MAX_LINE",
    "error",
    "internal_error",
    "interrupted",
    "one_line",
    "show_warnings",
    "shown_path",
]

MAX_LINE = 300


#: Longest quoted value or unbroken token kept whole in a refusal (a path, a pasted value).
MAX_QUOTED = 120


def _bounded_value(m) -> str:
    v = m.group(0)
    keep = MAX_QUOTED // 2
    return f"{v[:keep]}...{v[-keep:]}"


def one_line(text: str, limit: int | None = MAX_LINE) -> str:
    """``text`` on one line; of at most ``limit`` characters (the middle cut out), for a
    message from a library. ``None``, for the tool's own refusals: the words are kept
    whole and only a quoted value or an unbroken token longer than :data:`MAX_QUOTED`
    (a user's path or value) is shortened in its middle."""
    text = " ".join(str(text).split())
    if limit is None:
        n = MAX_QUOTED
        return re.sub(rf"'[^']{{{n},}}'|\"[^\"]{{{n},}}\"|[^\s'\"]{{{n},}}", _bounded_value, text)
    if len(text) <= limit:
        return text
    tail = limit // 3
    return f"{text[: limit - tail - 5]} ... {text[-tail:]}"


def error(msg: str) -> None:
    """A refusal's one line, whole: a suggested fix at its end is never cut off."""
    print(one_line(f"corr-cad: error: {msg}", None), file=sys.stderr)


def show_warnings(caught: list) -> None:
    """Warnings from numpy, matplotlib & co. as bounded one-line notes, never raw.

    Only a run that succeeds shows them (a failed run prints its one error
    line). Known causes are refused up front with the key that caused them;
    this is the net for the rest.
    """
    seen: dict[tuple[str, str], object] = {}
    for w in caught:
        seen.setdefault((w.category.__name__, str(w.message)), w)
    for i, ((cat, msg), w) in enumerate(seen.items()):
        if i == 3:
            print(f"corr-cad: warning: {len(seen) - 3} more numerical warnings", file=sys.stderr)
            break
        where = f"{Path(w.filename).name}:{w.lineno}"
        print(one_line(f"corr-cad: warning: {cat} in {where}: {msg}"), file=sys.stderr)


def interrupted(exc: KeyboardInterrupt, state: dict) -> int:
    """The one line of an interrupted run, and its exit status (130 SIGINT, 143 SIGTERM)."""
    from corr_cad.run import interrupts

    terminated = isinstance(exc, interrupts.Terminated)
    name, code = ("SIGTERM", 143) if terminated else ("SIGINT", 130)
    staging = state.get("staging")
    left = (
        "the new outputs were already in place"
        if staging is not None and staging.committed
        else "previous outputs left as they were"
    )
    print(f"corr-cad: interrupted ({name}); {left}", file=sys.stderr)
    return code


#: Exit code of an unexpected exception (a bug in corr-cad or a library it calls).
INTERNAL_ERROR = 3


def internal_error(exc: Exception, args: argparse.Namespace, state: dict) -> None:
    """The one stderr line of an unexpected exception: where, what, and what was lost.

    A run keeps all its files or none (docs/output-folder.md): the line says
    which finished stages' files were discarded with the failed one, or that
    the outputs were already in place. ``CORR_CAD_DEBUG=1`` prints the
    traceback first.
    """
    if os.environ.get("CORR_CAD_DEBUG", "") not in ("", "0"):
        import traceback

        traceback.print_exception(exc, file=sys.stderr)
    what = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
    what = one_line(what, 100)
    staging = state.get("staging")
    failure = getattr(exc, "corr_cad_failure", None)
    where = f" in stage {failure.stage}" if failure is not None else ""
    if args.command != "run":  # new, schema, bench: what they wrote is whole files
        lost = ""
    elif staging is not None and staging.committed:
        lost = f"the run's files are complete in {shown_path(staging.given)}"
    elif failure is not None and failure.finished:
        lost = (
            f"the {failure.files} files staged by {', '.join(failure.finished)} were discarded "
            "(a run keeps all its files or none) and "
            f"{shown_path(staging.given) if staging is not None else 'the output folder'} "
            "holds its previous outputs"
        )
    else:
        lost = "nothing was written; previous outputs left as they were"
    print(
        one_line(
            f"corr-cad: internal error{where} ({what}); {lost + '; ' if lost else ''}this is a "
            "bug, please report it with the scene (CORR_CAD_DEBUG=1 shows the traceback)",
            600,
        ),
        file=sys.stderr,
    )


def shown_path(name: object) -> str:
    """A file name for an error line: the path as given, its start cut if very long."""
    text = os.fsdecode(name) if isinstance(name, (str, bytes)) else str(name)
    return text if len(text) <= 160 else "..." + text[-157:]


def out_arg(text: str) -> Path | str:
    """A path argument; an empty one stays ``""`` and is refused in :func:`main`.

    ``Path("")`` is ``Path(".")``, the working folder; an empty argument is
    almost always an unset shell variable, never a request to write there.
    """
    return text if text == "" else Path(text)


def worker_list(text: str) -> list[int]:
    """``bench --workers 1,2,16``: worker counts, each a whole number from 1 to 1024."""
    try:
        counts = [int(x) for x in text.split(",")]
    except ValueError:
        counts = []
    if not counts or any(not 1 <= n <= 1024 for n in counts):
        raise argparse.ArgumentTypeError(
            f"{text!r}: worker counts from 1 to 1024, comma-separated (e.g. 1,2,4)"
        )
    return counts
