"""Reading an output folder's ``manifest.json`` without trusting it.

The manifest decides which files a run may replace or remove, so it is
checked in full before any of it is used: a ``manifest.json`` that is not
corr-cad's (another tool's file of that name) or that is corr-cad's but
malformed (a wrong JSON type anywhere, a name no format writes, a sha256
that is not one, a commit record that does not fit) refuses the run with one
line naming the file and the first thing wrong. Nothing in the folder is
touched then: the user decides what the file is.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

from corr_cad.bounds import show
from corr_cad.errors import OutputError
from corr_cad.run.folder.names import is_output_name

__all__ = ["MANIFEST_NAME", "GENERATOR", "STAGING_PREFIX", "read_manifest", "manifest_problem"]

MANIFEST_NAME = "manifest.json"
GENERATOR = "corr-cad"
STAGING_PREFIX = ".corr-cad-staging-"
#: Largest manifest read (a manifest of the largest scene is well below 1 MB).
MAX_MANIFEST_BYTES = 64 << 20
_SHA256 = re.compile(r"[0-9a-f]{64}")
#: ``tempfile.mkdtemp(prefix=STAGING_PREFIX + f"{pid}-")``: the only names a journal may give.
STAGING_NAME = re.compile(re.escape(STAGING_PREFIX) + r"[0-9]+-[A-Za-z0-9_]+")


def _kind(value: object) -> str:
    return {
        dict: "an object",
        list: "an array",
        str: "a string",
        bool: "a boolean",
        int: "a number",
        float: "a number",
        type(None): "null",
    }.get(type(value), type(value).__name__)


def _is_ours(data: object) -> bool:
    if not isinstance(data, dict):
        return False
    versions = data.get("versions")
    return data.get("generator") == GENERATOR or (
        isinstance(versions, dict) and "corr_cad" in versions
    )


def _sha_problem(where: str, value: object, nullable: bool = False) -> str | None:
    if value is None and nullable:
        return None
    if isinstance(value, str) and _SHA256.fullmatch(value):
        return None
    return f"{where} is {_kind(value)} {show(value, 20)}, not a sha256 (64 hex digits)"


def _name_problem(where: str, name: str) -> str | None:
    if is_output_name(name):
        return None
    return f"{where} names {show(name, 40)}, which no corr-cad format writes"


def _files_problem(files: object) -> str | None:
    if not isinstance(files, dict):
        return f"'files' is {_kind(files)}, not an object"
    for name, meta in files.items():
        where = f"files[{show(name, 40)}]"
        if p := _name_problem("files", name):
            return p
        if not isinstance(meta, dict):
            return f"{where} is {_kind(meta)}, not an object"
        if p := _sha_problem(f"{where}.sha256", meta.get("sha256")):
            return p
        size = meta.get("bytes")
        if isinstance(size, bool) or not isinstance(size, int) or size < 0:
            return f"{where}.bytes is {_kind(size)} {show(size, 20)}, not a byte count"
    return None


def _sha_map_problem(where: str, value: object) -> str | None:
    if not isinstance(value, dict):
        return f"{where} is {_kind(value)}, not an object"
    for name, sha in value.items():
        if p := _name_problem(where, name):
            return p
        if p := _sha_problem(f"{where}[{show(name, 40)}]", sha, nullable=True):
            return p
    return None


def _commit_problem(data: dict) -> str | None:
    complete = data.get("complete", True)
    if not isinstance(complete, bool):
        return f"'complete' is {_kind(complete)}, not true or false"
    if complete:
        return "a complete manifest has a 'commit' record" if "commit" in data else None
    commit = data.get("commit")
    if not isinstance(commit, dict):
        return f"'complete' is false but 'commit' is {_kind(commit)}, not an object"
    stage = commit.get("staging")
    if not (isinstance(stage, str) and STAGING_NAME.fullmatch(stage)):
        return f"commit.staging is {_kind(stage)} {show(stage, 40)}, not a staging folder name"
    for key in ("replaces", "remove"):
        if p := _sha_map_problem(f"commit.{key}", commit.get(key)):
            return p
    return None


def manifest_problem(data: object) -> str | None:
    """What is wrong with a parsed corr-cad manifest (None: nothing).

    >>> manifest_problem({"generator": "corr-cad", "complete": True, "files": []})
    "'files' is an array, not an object"
    >>> manifest_problem({"generator": "corr-cad", "files": {"notes.txt": {}}})
    "files names 'notes.txt', which no corr-cad format writes"
    """
    assert isinstance(data, dict)
    return _files_problem(data.get("files")) or _commit_problem(data)


def read_manifest(folder: Path) -> dict | None:
    """The corr-cad manifest in ``folder``, checked in full; None if there is none.

    Refused (:class:`OutputError`, nothing touched): a ``manifest.json`` that
    is a symlink or not a regular file, one that is not corr-cad's, and one
    that is corr-cad's but malformed (:func:`manifest_problem`).
    """
    p = Path(folder) / MANIFEST_NAME
    if not os.path.lexists(p):
        return None
    if p.is_symlink() or not p.is_file():
        raise OutputError(
            f"{p}: is a symlink or not a regular file; corr-cad leaves it alone - "
            "move it away or choose another --out"
        )
    try:
        with open(p, "rb") as f:
            data = json.loads(f.read(MAX_MANIFEST_BYTES))
    except (ValueError, UnicodeDecodeError, RecursionError):
        data = None
    except OSError as exc:
        raise OutputError(f"{p}: cannot be read ({exc.strerror or exc})") from exc
    if not _is_ours(data):
        raise OutputError(
            f"{p}: exists and was not written by corr-cad; it is left alone - "
            "move it away or choose another --out"
        )
    problem = manifest_problem(data)
    if problem:
        raise OutputError(
            f"{p}: is not a valid corr-cad manifest ({problem}); nothing in the folder was "
            "touched - move it away or choose another --out"
        )
    return data
