"""The output folder contract, issue 21: holes an adversarial tester found.

Like ``test_output_contract.py``: every test runs ``python -m corr_cad`` in
its own process on a real folder that holds other files, and reads what it
checks with ``json``, ``hashlib`` and ``os`` (no code shared with
``corr_cad/run/folder/outputs.py``).
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.helpers import without_progress

DESIGN = """
[design]
tooth_count = 8
cam_radius = 40.0
roller_radius = 4.0
roller_length = 6.0
eccentricity = 1.5
"""
DXF_SCENE = DESIGN + '[export]\nformats = ["dxf"]\ntolerance = 0.01\n'
DXF_PNG_SCENE = DESIGN + '[export]\nformats = ["dxf", "png"]\ntolerance = 0.01\n'


def cli(*args, cwd=None, timeout=600):
    return subprocess.run(
        [sys.executable, "-m", "corr_cad", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=timeout,
    )


def sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def snapshot(folder: Path) -> dict:
    out = {}
    for p in sorted(folder.rglob("*")):
        key = str(p.relative_to(folder))
        if p.is_symlink():
            out[key] = ("link", os.readlink(p))
        elif p.is_dir():
            out[key] = ("dir",)
        else:
            out[key] = ("file", p.read_bytes())
    return out


def one_line(r, code=2, limit=300):
    assert r.returncode == code, (r.returncode, r.stderr[-2000:])
    assert "Traceback" not in r.stderr, r.stderr[-2000:]
    lines = without_progress(r.stderr).strip().splitlines()
    assert len(lines) == 1, r.stderr[-2000:]
    # The limit is the message's, not the test's temporary path (its length varies with
    # the machine and the worker: /tmp/pytest-of-root/pytest-282/popen-gw0/...).
    message = re.sub(r"\S*/pytest-of-[^/\s]+/\S*", "PATH", lines[0])
    assert len(message) <= limit, len(message)
    return lines[0]


@pytest.fixture(scope="module")
def _one_run(tmp_path_factory):
    """One complete DXF+PNG run, made once for the module (a run per test cost ~2 s)."""
    folder = tmp_path_factory.mktemp("done")
    scene = folder / "s.toml"
    scene.write_text(DXF_PNG_SCENE)
    r = cli("run", scene, "--out", folder / "o", "--quiet")
    assert r.returncode == 0, r.stderr
    return folder / "o"


@pytest.fixture
def done(tmp_path, _one_run):
    """A folder with a complete DXF+PNG run in it and the user's notes beside it.

    A copy of the module's one run: ``manifest.json`` holds no absolute path,
    so the copy is that run's folder as the next run finds it."""
    scene = tmp_path / "s.toml"
    scene.write_text(DXF_PNG_SCENE)
    out = tmp_path / "o"
    shutil.copytree(_one_run, out, symlinks=True)
    (out / "notes.txt").write_text("my notes\n")
    return scene, out


def _edit(out: Path, change) -> None:
    m = json.loads((out / "manifest.json").read_text())
    change(m)
    (out / "manifest.json").write_text(json.dumps(m))


NOTES = {"sha256": sha(b"my notes\n"), "bytes": 9}


def _journal(m: dict, **commit) -> None:
    m["complete"] = False
    m["commit"] = {"staging": ".corr-cad-staging-1-abcdefgh", "replaces": {}, "remove": {}}
    m["commit"].update(commit)


#: Manifests that claim the user's notes.txt as corr-cad's, each a different way.
CLAIMS = {
    "files": lambda m: m["files"].update({"notes.txt": NOTES}),
    "journal remove": lambda m: _journal(m, remove={"notes.txt": NOTES["sha256"]}),
    "journal files": lambda m: (_journal(m), m["files"].update({"notes.txt": NOTES})),
    "journal replaces": lambda m: _journal(m, replaces={"notes.txt": NOTES["sha256"]}),
}


@pytest.mark.parametrize("how", sorted(CLAIMS))
def test_a_manifest_cannot_claim_a_users_file(done, how):
    """A manifest listing notes.txt with its sha256 made the next run delete it."""
    scene, out = done
    scene.write_text(DXF_SCENE)  # png no longer produced: the previous set's extras go
    _edit(out, CLAIMS[how])
    before = snapshot(out)
    err = one_line(cli("run", scene, "--out", out))
    assert "manifest.json" in err and "notes.txt" in err
    assert snapshot(out) == before


def _set(path: list, value):
    def change(m):
        d = m
        for k in path[:-1]:
            d = d[k]
        d[path[-1]] = value

    return change


def _journal_with(key: str, value):
    if key == "commit":
        return lambda m: (_journal(m), m.update(commit=value))
    return lambda m: _journal(m, **{key: value})


#: Every place of the manifest, given every wrong JSON type.
BAD_TYPES = [[], "x", 1, 1.5, None, True, {}]
BAD_STAGING = ["..", "sub/.corr-cad-staging-1-a", ".corr-cad-staging-1-x/../.."]
MUTATIONS = {
    **{f"files={v!r}": _set(["files"], v) for v in BAD_TYPES if v != {}},
    **{f"entry={v!r}": _set(["files", "roller.dxf"], v) for v in BAD_TYPES if v != {}},
    **{f"sha256={v!r}": _set(["files", "roller.dxf", "sha256"], v) for v in BAD_TYPES},
    **{
        f"bytes={v!r}": _set(["files", "roller.dxf", "bytes"], v)
        for v in [*BAD_TYPES, -1]
        if v != 1
    },
    **{f"complete={v!r}": _set(["complete"], v) for v in BAD_TYPES if v is not True},
    "sha256 upper case": lambda m: m["files"]["roller.dxf"].update(
        sha256=m["files"]["roller.dxf"]["sha256"].upper()
    ),
    "a nested name": lambda m: m["files"].update({"../roller.dxf": NOTES}),
    "commit when complete": lambda m: m.update(commit={}),
    **{f"commit={v!r}": _journal_with("commit", v) for v in BAD_TYPES},
    **{f"staging={v!r}": _journal_with("staging", v) for v in [*BAD_TYPES, *BAD_STAGING]},
    **{f"replaces={v!r}": _journal_with("replaces", v) for v in BAD_TYPES if v != {}},
    **{f"remove={v!r}": _journal_with("remove", v) for v in BAD_TYPES if v != {}},
    "remove sha 1": _journal_with("remove", {"preview.png": 1}),
}


@pytest.mark.parametrize("name", list(MUTATIONS))
def test_malformed_manifest_is_refused_in_one_line(done, name):
    """Wrong JSON types in 'files' or 'commit' gave AttributeError/TypeError tracebacks."""
    scene, out = done
    try:
        _edit(out, MUTATIONS[name])
    except (KeyError, TypeError):
        pytest.skip("mutation does not apply")
    before = snapshot(out)
    err = one_line(cli("run", scene, "--out", out))
    assert "manifest.json" in err and "not a valid corr-cad manifest" in err, err
    assert snapshot(out) == before


@pytest.mark.parametrize("text", ["[]", '"corr-cad"', "1", "null", "[" * 100000, '{"files": 1}'])
def test_foreign_json_manifest_is_refused(tmp_path, text):
    scene = tmp_path / "s.toml"
    scene.write_text(DXF_SCENE)
    out = tmp_path / "o"
    out.mkdir()
    (out / "manifest.json").write_text(text)
    before = snapshot(tmp_path)
    err = one_line(cli("run", scene, "--out", out))
    assert "manifest.json" in err and "not written by corr-cad" in err
    assert snapshot(tmp_path) == before


def test_recovery_removes_only_its_own_staging_folders(done):
    """Recovery deleted any manifest.json.*.part, a user's file included."""
    scene, out = done
    (out / "manifest.json.mine.part").write_text("mine\n")
    (out / "manifest.json.a1b2c3d4.part").write_text("looks like a temporary, is mine\n")
    (out / ".corr-cad-staging-photos").mkdir()
    (out / ".corr-cad-staging-photos" / "cat.jpg").write_bytes(b"\xff\xd8")
    (out / ".corr-cad-staging-1-file").write_text("a file, not a folder\n")
    mine = {k: v for k, v in snapshot(out).items() if "staging" in k or k.endswith(".part")}
    r = cli("run", scene, "--out", out, "--quiet")
    assert r.returncode == 0, r.stderr
    after = snapshot(out)
    for key, value in mine.items():
        assert after.get(key) == value, key
    assert (out / "notes.txt").read_text() == "my notes\n"


def test_every_format_declares_its_names():
    from corr_cad.run.folder.names import OUTPUT_PATTERNS
    from corr_cad.run.scene.scene_schema import FORMATS

    assert set(OUTPUT_PATTERNS) == set(FORMATS)


# --- the command line's own files -------------------------------------------


@pytest.mark.parametrize(
    "args", [("run", "s.toml", "--out", ""), ("schema", "--out", ""), ("new", "")]
)
def test_empty_path_is_refused(tmp_path, args):
    """--out "" wrote into the working folder."""
    (tmp_path / "s.toml").write_text(DXF_SCENE)
    (tmp_path / "notes.txt").write_text("mine\n")
    before = snapshot(tmp_path)
    err = one_line(cli(*args, cwd=tmp_path))
    assert "''" in err and "empty" in err
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("command", ["schema", "new"])
def test_schema_and_new_never_overwrite(tmp_path, command):
    """schema --out replaced a user's file; both replaced a user's '<name>.part'."""
    (tmp_path / "user.json").write_text('{"mine": true}\n')
    (tmp_path / "fresh.json.part").write_text("mine too\n")
    before = snapshot(tmp_path)
    args = ("schema", "--out") if command == "schema" else ("new",)
    err = one_line(cli(*args, "user.json", cwd=tmp_path))
    assert "user.json" in err and "exists" in err
    assert snapshot(tmp_path) == before
    r = cli(*args, "fresh.json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert snapshot(tmp_path).items() >= before.items()
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "fresh.json",
        "fresh.json.part",
        "user.json",
    ]


# --- a full disk (needs root for the tmpfs) -----------------------------------


@pytest.fixture
def tiny_fs(tmp_path):
    mnt = tmp_path / "fs"
    mnt.mkdir()
    r = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=200k", "tmpfs", str(mnt)], capture_output=True
    )
    if r.returncode != 0:
        pytest.skip("cannot mount a tmpfs here (needs root)")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], check=False)


def _fill(fs: Path, leave: int) -> None:
    free = os.statvfs(fs)
    (fs / "filler.bin").write_bytes(b"\0" * max(0, free.f_bavail * free.f_frsize - leave))


#: The run with its up-front disk check taken out: the disk fills while it writes
#: (another process filling it meanwhile; the estimate is never below the files).
NO_DISK_CHECK = """
import sys
from corr_cad.run.budget import resources
resources.check_disk = lambda est, out: None
from corr_cad.run.cli import main
sys.exit(main(["run", *sys.argv[1:]]))
"""


@pytest.mark.parametrize("leave", [0, 48 * 1024])
def test_full_disk_names_the_file_and_leaves_nothing(tiny_fs, tmp_path, leave):
    """No file named, and a new --out folder left behind with its lock file."""
    scene = tmp_path / "s.toml"
    scene.write_text(DXF_PNG_SCENE.replace('["dxf", "png"]', '["dxf", "png", "stl"]'))
    (tiny_fs / "mine.txt").write_text("mine\n")
    _fill(tiny_fs, leave)
    before = snapshot(tiny_fs)
    out = tiny_fs / "new" / "o"
    # Refused before anything is created: the files would not fit.
    err = one_line(cli("run", scene, "--out", out))
    assert "of files;" in err and "MB free; free some space or choose another --out" in err
    assert snapshot(tiny_fs) == before
    # Filled while writing: the file it could not write is named.
    r = subprocess.run(
        [sys.executable, "-c", NO_DISK_CHECK, str(scene), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    err = one_line(r)
    assert "No space left on device" in err
    named = re.search(re.escape(str(out)) + r"/([^/:]+): No space left", err)
    assert named, err
    assert not named.group(1).startswith(".corr-cad-staging"), err
    assert snapshot(tiny_fs) == before


# --- corr-cad bench --out --------------------------------------------------------------
def test_bench_refuses_a_folder_it_did_not_write(tmp_path):
    """A user's speed.csv beside the bench's would-be tables is never replaced."""
    (tmp_path / "solver_speed.csv").write_text("mine\n")
    r = cli("bench", "--out", str(tmp_path), "--study", "kernel", "--quick")
    assert r.returncode == 2, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "did not write" in r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["solver_speed.csv"]
    assert (tmp_path / "solver_speed.csv").read_text() == "mine\n"
    f = tmp_path / "file"
    f.write_text("x")
    r = cli("bench", "--out", str(f), "--study", "kernel", "--quick")
    assert r.returncode == 2 and "not a folder" in r.stderr and f.read_text() == "x"


def test_bench_writes_into_its_own_folder(tmp_path):
    from corr_cad.run.bench.bench import check_bench_folder

    check_bench_folder(tmp_path / "new")  # absent: fine
    check_bench_folder(tmp_path)  # empty: fine
    (tmp_path / "machine.json").write_text('{"corr_cad": "0.1.0", "cores": 2}')
    (tmp_path / "solver_speed.csv").write_text("an earlier bench's table\n")
    check_bench_folder(tmp_path)  # a bench folder: fine
