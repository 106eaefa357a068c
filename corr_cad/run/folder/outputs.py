"""The output folder contract: never touch what corr-cad did not write.

A run writes into a hidden staging folder *inside* the target
(``<out>/.corr-cad-staging-<pid>-<random>/``, so every move is a rename on
one file system) and commits file by file:

1. every staged file is hashed (and synced); a file of the new set whose name
   exists in the folder may be replaced only if the previous ``manifest.json``
   lists it with the sha256 it still has (it is corr-cad's own); a symlink,
   folder or foreign file of that name refuses the run before anything moves;
2. ``manifest.json`` is replaced atomically by a journal version:
   ``"complete": false``, the new file list with sha256, and a ``"commit"``
   record (staging folder, the hashes of the files it replaces, the previous
   run's files to remove);
3. each new file is moved into place with ``os.replace``;
4. files of the previous run that the new one no longer writes are removed
   if they still have their recorded sha256 (an edited one is left, with a
   warning);
5. ``manifest.json`` is replaced atomically by the final ``"complete": true``
   version; the empty staging folder is removed.

SIGINT and SIGTERM arriving during steps 2-5 are held until step 5 is done.
A run that finds ``"complete": false`` (a SIGKILL or power loss between
2 and 5) finishes the moves from the staging folder it names, or, if that
cannot be done, removes that set's files (those still matching their sha256)
and its manifest; then it removes staging leftovers. All of this happens
under an exclusive ``flock`` on ``<out>/.corr-cad.lock``, a file that exists
only while a run holds it. A run that fails before its commit removes the
folders, staging folder and lock file it created (a refused run, a full disk
included, leaves nothing).

What a run may replace or remove is fixed by the code, never widened by a
manifest: a file whose name some format writes (:mod:`corr_cad.run.folder.names`)
and whose sha256 the manifest records, ``manifest.json`` itself, its own
lock file (content ``corr-cad lock``) and staging folders that carry the
staging mark. ``manifest.json`` is checked in full before any of it is used
(:mod:`corr_cad.run.folder.manifest_file`); a foreign or malformed one refuses the
run. No temporary file is ever made in the output folder itself: every
temporary lies in a marked staging folder.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import signal
import sys
import tempfile
import threading
from collections.abc import Callable, Iterable
from pathlib import Path

from corr_cad.errors import CorrCadError, ExportError, OutputError
from corr_cad.export.files import _umask, sha256_of, write_json
from corr_cad.run import interrupts
from corr_cad.run.folder.lockfile import LOCK_NAME, lock_wait_s
from corr_cad.run.folder.lockfile import lock as _lock
from corr_cad.run.folder.lockfile import unlock as _unlock
from corr_cad.run.folder.manifest_file import (
    GENERATOR,
    MANIFEST_NAME,
    STAGING_NAME,
    STAGING_PREFIX,
    read_manifest,
)
from corr_cad.run.folder.names import is_output_name

__all__ = [
    "StagingDir",
    "safe_folder_name",
    "check_out_dir",
    "read_manifest",
    "MANIFEST_NAME",
    "LOCK_NAME",
    "STAGING_PREFIX",
]

#: Written into every staging folder on creation: only folders holding it are
#: ever removed as leftovers (a user's folder that merely has the name is not).
STAGING_MARK = ".corr-cad-staging"
_JOURNAL_TMP = ".manifest.journal.json"


# --- the output folder -----------------------------------------------------


def safe_folder_name(stem: str) -> str:
    """A folder name from a scene file's stem: never ``.``, ``..``, hidden or nested.

    Runs of characters other than letters, digits, ``.``, ``_``, ``+``, ``-``
    (separators, spaces, control characters) become one ``_``; leading and
    trailing dots are dropped; the name is cut to 100 bytes; an empty result
    is ``scene``.

    >>> [safe_folder_name(s) for s in (".", "..", "my scene", "a\\\\b", ".hidden")]
    ['scene', 'scene', 'my_scene', 'a_b', 'hidden']
    """
    name = re.sub(r"[^\w.+-]+", "_", stem).strip(".")
    while len(name.encode("utf-8")) > 100:
        name = name[:-1]
    name = name.strip(".")
    return name or "scene"


def check_out_dir(out: Path) -> Path:
    """The output folder, resolved, if it can be used; creates nothing.

    Refused (:class:`OutputError`): an existing file, ``/``, a mount point, a
    path below an existing file, a folder that is not writable or whose
    nearest existing parent is not writable.
    """
    given = str(out)
    try:
        real = Path(out).expanduser().resolve()
    except (OSError, RuntimeError) as exc:  # symlink loops
        raise OutputError(f"--out {given!r}: cannot be resolved ({exc})") from exc
    if real == Path(real.anchor):
        raise OutputError(f"--out {given!r}: resolves to {real}; give a folder below it")
    if any(len(part.encode("utf-8", "surrogateescape")) > 255 for part in real.parts):
        raise OutputError(f"--out: a folder name is longer than 255 bytes ({given[:60]!r}...)")
    if os.path.lexists(real):
        if not real.is_dir():
            raise OutputError(f"--out {given!r}: is an existing file; give a folder")
        if os.path.ismount(real):
            raise OutputError(
                f"--out {given!r}: is a mount point; give a folder inside it (e.g. {real}/out)"
            )
        if not os.access(real, os.W_OK | os.X_OK):
            raise OutputError(f"--out {given!r}: folder is not writable")
        return real
    parent = real.parent
    while not os.path.lexists(parent):
        parent = parent.parent
    if not parent.is_dir():
        raise OutputError(f"--out {given!r}: lies below {parent}, which is a file, not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(f"--out {given!r}: cannot be created, {parent} is not writable")
    return real


def _regular(p: Path) -> bool:
    return not p.is_symlink() and p.is_file()


def _matches(p: Path, sha: str | None) -> bool:
    return sha is not None and _regular(p) and sha256_of(p) == sha


def _remove_stale(folder: Path, stale: dict, say: Callable[[str], None]) -> None:
    """Remove files of a previous run that still carry their recorded sha256."""
    for name, sha in sorted(stale.items()):
        if not is_output_name(name):  # never a user's name, whatever a manifest says
            continue
        p = folder / name
        if not os.path.lexists(p):
            continue
        if _matches(p, sha):
            p.unlink()
        else:
            say(f"corr-cad: warning: {p} is from an earlier run but was changed; left in place")


def _fsync_dir(folder: Path) -> None:
    fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _is_stage(p: Path) -> bool:
    """A staging folder corr-cad made: our name pattern, a real folder, our mark inside."""
    mark = p / STAGING_MARK
    return (
        STAGING_NAME.fullmatch(p.name) is not None
        and not p.is_symlink()
        and p.is_dir()
        and mark.is_file()
        and not mark.is_symlink()
    )


def _make_stage(folder: Path) -> Path:
    """A new, marked staging folder in ``folder`` (removed again if marking it fails)."""
    path = Path(tempfile.mkdtemp(dir=folder, prefix=f"{STAGING_PREFIX}{os.getpid()}-"))
    try:
        os.chmod(path, 0o777 & ~_umask())
        (path / STAGING_MARK).write_bytes(b"")
    except BaseException:
        shutil.rmtree(path, ignore_errors=True)
        raise
    return path


def _write_manifest(folder: Path, data: dict) -> None:
    """Replace ``folder/manifest.json`` atomically, its temporary in a marked staging folder.

    No temporary ever lies in the output folder itself under a name a user
    could have: a leftover is a marked staging folder, removed by the next run.
    """
    stage = _make_stage(folder)
    try:
        write_json(stage / MANIFEST_NAME, data)
        os.replace(stage / MANIFEST_NAME, folder / MANIFEST_NAME)
        _fsync_dir(folder)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def _roll_forward(folder: Path, journal: dict, say: Callable[[str], None]) -> None:
    """Finish (or undo) a commit that was interrupted after its journal was written.

    ``journal`` has passed :func:`read_manifest`: every name in it is an
    output name, every sha256 well formed, the staging name ours.
    """
    files: dict[str, dict] = journal["files"]
    commit: dict = journal["commit"]
    stage = folder / commit["staging"]
    if not _is_stage(stage):
        stage = None  # gone, or not ours: nothing is moved out of it
    replaces: dict = commit["replaces"]
    stale: dict = commit["remove"]
    missing = []
    moved = 0
    for name, meta in sorted(files.items()):
        sha = meta["sha256"]
        dst = folder / name
        if _matches(dst, sha):
            continue
        src = stage / name if stage is not None else None
        may_replace = not os.path.lexists(dst) or _matches(dst, replaces.get(name))
        if src is not None and may_replace and _matches(src, sha):
            os.replace(src, dst)
            moved += 1
        else:
            missing.append(name)
    if missing:
        # Cannot finish: remove every file of either set that is still corr-cad's
        # (new sha256, the sha256 it replaced, or a stale file of the previous run).
        removed = 0
        for name in sorted(set(files) | set(stale)):
            p = folder / name
            shas = {files[name]["sha256"] if name in files else None}
            shas |= {replaces.get(name), stale.get(name)}
            if _regular(p) and sha256_of(p) in shas - {None}:
                p.unlink()
                removed += 1
        (folder / MANIFEST_NAME).unlink()
        say(
            f"corr-cad: warning: {folder}: an interrupted run's output set could not be "
            f"completed ({len(missing)} files missing, e.g. {missing[0]}); removed the "
            f"{removed} files it and the run before had written, and the manifest"
        )
        return
    _remove_stale(folder, stale, say)
    final = {k: v for k, v in journal.items() if k != "commit"}
    final["complete"] = True
    _write_manifest(folder, final)
    say(
        f"corr-cad: note: {folder}: finished moving an interrupted run's outputs into place "
        f"({moved} files moved); manifest.json is complete again"
    )


def recover(folder: Path, say: Callable[[str], None]) -> None:
    """Repair an interrupted commit and remove staging leftovers (under the lock).

    Only corr-cad's own staging folders are removed (:func:`_is_stage`); any
    other entry, whatever its name, is left alone.
    """
    m = read_manifest(folder)
    if m is not None and m.get("complete") is False:
        _roll_forward(folder, m, say)
    for entry in sorted(os.scandir(folder), key=lambda e: e.name):
        if not entry.name.startswith(STAGING_PREFIX):
            continue
        if _is_stage(Path(entry.path)):
            shutil.rmtree(entry.path)
            say(f"corr-cad: note: removed {entry.name}, left by an interrupted run")
        elif entry.is_dir(follow_symlinks=False):
            say(f"corr-cad: warning: {entry.name} is not a corr-cad staging folder; left alone")


@contextlib.contextmanager
def _held_signals():
    """Hold SIGINT/SIGTERM while the commit runs; deliver them afterwards."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got: list[int] = []
    sigs = (signal.SIGINT, signal.SIGTERM)
    old = {s: signal.signal(s, lambda n, f: got.append(n)) for s in sigs}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        if got:
            handler = old[got[0]]
            if callable(handler):
                handler(got[0], None)
            elif handler == signal.SIG_DFL:
                os.kill(os.getpid(), got[0])


def _stderr(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


class StagingDir:
    """Context manager: stage inside the target folder, commit file by file on success.

    >>> with StagingDir(Path("outputs/x")) as stage:   # doctest: +SKIP
    ...     (stage / "a.txt").write_text("...")

    ``committed`` tells afterwards whether the new set is in place. Warnings
    and repair notes go to ``say`` (default: stderr).
    """

    def __init__(
        self,
        target: Path,
        lock_wait_s: float | None = None,
        say: Callable[[str], None] | None = None,
        formats: Iterable[str] | None = None,
    ):
        self.given = Path(target)
        #: The scene's formats: a staged file must have a name one of them writes.
        self.formats = tuple(formats) if formats is not None else None
        self.target: Path | None = None
        self.path: Path | None = None
        self.lock_wait_s = lock_wait_s
        self.say = say or _stderr
        self.committed = False
        self._fd: int | None = None
        self._lock_path: Path | None = None
        self._created: list[Path] = []

    def __enter__(self) -> Path:
        wait = self.lock_wait_s if self.lock_wait_s is not None else lock_wait_s()
        self.target = check_out_dir(self.given)
        created = []
        p = self.target
        while not os.path.lexists(p):
            created.append(p)
            p = p.parent
        self._created = created  # deepest first: removed again if the run fails
        try:
            self.target.mkdir(parents=True, exist_ok=True)
            self._fd, self._lock_path = _lock(self.target, wait)
            recover(self.target, self.say)
            read_manifest(self.target)  # a foreign manifest.json refuses before the work
            self.path = _make_stage(self.target)
        except BaseException as exc:
            self._unlock()
            named = self._named(exc)
            if named is exc:
                raise
            raise named from exc
        return self.path

    def _named(self, exc: BaseException) -> BaseException:
        """An OSError naming a file in the staging folder, renamed to that file in the target.

        The staging folder is gone when the user reads the message; the file
        it could not write is the output name (``<out>/roller.stl``).
        """
        if not isinstance(exc, OSError) or isinstance(exc, CorrCadError) or not exc.filename:
            return exc
        name = os.fsdecode(exc.filename)
        if self.path is not None and self.target is not None:
            stage = str(self.path) + os.sep
            if name.startswith(stage):
                name = str(self.target / name[len(stage) :].split(os.sep)[0])
        return OSError(exc.errno, exc.strerror or str(exc), name)

    def _unlock(self) -> None:
        if self._fd is not None:
            _unlock(self._fd, self._lock_path)
            self._fd = None
        if not self.committed:
            for p in self._created:  # a failed run leaves no folder behind
                try:
                    p.rmdir()
                except OSError:
                    break

    def __exit__(self, exc_type, exc, tb) -> None:
        assert self.path is not None and self.target is not None
        keep_stage = False
        try:
            if exc_type is None:
                interrupts.check()  # one swallowed on the way (a GC callback) stops it here
                keep_stage = True
                self._commit()
                keep_stage = False
        except _PastNoReturn:
            raise
        except BaseException as err:
            keep_stage = False
            exc = err
            raise
        finally:
            if not keep_stage:
                shutil.rmtree(self.path, ignore_errors=True)
            self._unlock()
            if exc is not None and not isinstance(exc, _PastNoReturn):
                named = self._named(exc)
                if named is not exc:
                    raise named from exc

    def _commit(self) -> None:
        target, stage = self.target, self.path
        prev = read_manifest(target)
        prev_files = prev["files"] if prev else {}
        new: dict[str, dict] = {}
        for entry in sorted(os.scandir(stage), key=lambda e: e.name):
            if entry.name in (MANIFEST_NAME, STAGING_MARK):
                continue
            if not entry.is_file(follow_symlinks=False):
                raise ExportError(f"staged output {entry.name!r} is not a regular file")
            if not is_output_name(entry.name, self.formats):
                # A stage wrote a name corr_cad.run.folder.names does not declare: a bug,
                # refused before anything moves (the name could be a user's).
                raise ExportError(
                    f"staged output {entry.name!r} is not a name the scene's formats declare"
                )
            new[entry.name] = {
                "sha256": sha256_of(Path(entry.path), sync=True),
                "bytes": entry.stat(follow_symlinks=False).st_size,
            }
        replaces: dict[str, str | None] = {}
        for name in new:
            dst = target / name
            if not os.path.lexists(dst):
                replaces[name] = None
                continue
            if dst.is_symlink() or not dst.is_file():
                raise OutputError(
                    f"{dst}: is a symlink or folder that corr-cad did not write; it is left "
                    "alone - move it away or choose another --out"
                )
            old = prev_files[name]["sha256"] if name in prev_files else None
            if not _matches(dst, old):
                raise OutputError(
                    f"{dst}: was not written by corr-cad (or was changed since); it is left "
                    "alone - move it away or choose another --out"
                )
            replaces[name] = old
        stale = {n: m["sha256"] for n, m in prev_files.items() if n not in new}
        manifest: dict = {}
        if (stage / MANIFEST_NAME).is_file():
            with open(stage / MANIFEST_NAME, encoding="utf-8") as f:
                manifest = json.load(f)
        manifest.update({"generator": GENERATOR, "complete": True, "files": new})
        write_json(stage / MANIFEST_NAME, manifest)
        journal = {
            **manifest,
            "complete": False,
            "commit": {"staging": stage.name, "replaces": replaces, "remove": stale},
        }
        write_json(stage / _JOURNAL_TMP, journal)
        _fsync_dir(stage)
        with _held_signals():
            os.replace(stage / _JOURNAL_TMP, target / MANIFEST_NAME)
            try:
                _fsync_dir(target)
                for name in new:
                    os.replace(stage / name, target / name)
                _remove_stale(target, stale, self.say)
                os.replace(stage / MANIFEST_NAME, target / MANIFEST_NAME)
                _fsync_dir(target)
                self.committed = True
            except BaseException as exc:
                # The journal names the staging folder: keep it, the next run finishes.
                raise _PastNoReturn(
                    f"{target}: interrupted while moving outputs into place ({exc}); "
                    "the next run into this folder finishes the move"
                ) from exc


class _PastNoReturn(OutputError):
    """The commit failed after its journal was written; the staging folder is kept."""
