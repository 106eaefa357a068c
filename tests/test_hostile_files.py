"""Hostile measured-profile files, made here, refused in one line under a memory cap.

Each file is given as ``[errors] measured_profile`` (or row B's) and the real
command runs with its address space capped at 1 GB (``RLIMIT_AS``): a DXF
whose arcs or spline would flatten to millions of points is refused before a
point is made, naming the key and the size; a file of environment variables,
a CSV of terminal escapes or a binary file is named by where it goes wrong,
and nothing of it is shown.
"""

from __future__ import annotations

import math
import re
import resource
import subprocess
import sys
from pathlib import Path

import ezdxf
import numpy as np
import pytest

from tests.test_hostile_inputs import refused
from tests.test_inputs_issue21 import DESIGN


@pytest.fixture
def folder(tmp_path):
    (tmp_path / "notes.txt").write_text("mine\n")
    return tmp_path


#: The address-space cap of every run here: the tool itself needs about 600 MB of it.
CAP_BYTES = 1 << 30


def _capped() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (CAP_BYTES, CAP_BYTES))


def run_capped(folder: Path, scene: str, *extra: str) -> subprocess.CompletedProcess:
    (folder / "s.toml").write_text(scene)
    return subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", *extra],
        capture_output=True,
        text=True,
        cwd=folder,
        timeout=600,
        preexec_fn=_capped,
    )


def _scene(name: str, row: str = "errors") -> str:
    return DESIGN + f'[export]\nformats = ["dxf"]\n[{row}]\nmeasured_profile = "{name}"\n'


def bulge_bomb(path: Path, vertices: int = 2000, radius: float = 1e9) -> None:
    """A closed LWPOLYLINE of ``vertices`` bulged vertices on a circle of ``radius`` mm."""
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    t = np.linspace(0.0, 2 * np.pi, vertices, endpoint=False)
    bulge = math.tan(np.pi / vertices / 2)  # each arc a piece of the circle
    rows = [(radius * math.cos(a), radius * math.sin(a), 0.0, 0.0, bulge) for a in t]
    doc.modelspace().add_lwpolyline(
        rows, format="xyseb", close=True, dxfattribs={"layer": "MEASURED_PROFILE"}
    )
    doc.saveas(path)


def spline_bomb(path: Path, radius: float = 1e15, points: int = 200) -> None:
    """A closed cubic SPLINE (first and last control points equal) of coordinates ``radius``."""
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    t = np.linspace(0.0, 2 * np.pi, points)
    ctrl = [(radius * math.cos(a), radius * math.sin(a)) for a in t]
    ctrl[-1] = ctrl[0]
    doc.modelspace().add_open_spline(ctrl, degree=3, dxfattribs={"layer": "MEASURED_PROFILE"})
    doc.saveas(path)


def test_a_bulge_bomb_is_refused_before_it_is_flattened(folder):
    bulge_bomb(folder / "ring.dxf")
    assert (folder / "ring.dxf").stat().st_size < 200_000
    line = refused(folder, run_capped(folder, _scene("ring.dxf")), "ring.dxf")
    assert line.startswith("corr-cad: error: [errors] measured_profile: 'ring.dxf': ")
    assert "its 2000 bulged vertices would flatten to 7.0" in line, line  # 7.0e+06 points
    assert "(chords within 0.1 um, about 322 MB of memory); at most 4000000 are read" in line


def test_the_memory_budget_lowers_the_points_a_contour_may_flatten_to(folder):
    bulge_bomb(folder / "ring.dxf", radius=2.5e8)  # 3.5e6 points: below the fixed limit
    r = run_capped(folder, _scene("ring.dxf"), "--max-memory", "0.25")
    line = refused(folder, r, "ring.dxf")
    allowed = int(re.search(r"at most (\d+) are read", line).group(1))
    # what 0.25 GB leaves beside the process (over 100 MB), at 48 bytes a point
    assert allowed < (0.25 * 2**30 - 100 * 2**20) / 48 < 4_000_000, line
    assert "its 2000 bulged vertices would flatten to 3.5" in line, line


@pytest.mark.slow
def test_the_5_mb_bulge_bomb_asks_for_nothing(folder):
    bulge_bomb(folder / "ring.dxf", vertices=75_000)
    assert (folder / "ring.dxf").stat().st_size > 5_000_000
    line = refused(folder, run_capped(folder, _scene("ring.dxf")), "ring.dxf")
    assert "its 75000 bulged vertices would flatten to 7.0" in line and "MB of memory" in line


def test_a_spline_of_coordinates_1e15_is_refused_at_once(folder):
    spline_bomb(folder / "ring.dxf")
    line = refused(folder, run_capped(folder, _scene("ring.dxf")), "ring.dxf")
    assert line.startswith("corr-cad: error: [errors] measured_profile: 'ring.dxf': ")
    assert "its spline of 200 control points would flatten to " in line, line


SECRETS = ("API_TOKEN", "sk-live", "HOME=", "pwned")


@pytest.mark.parametrize(
    "name,content,where",
    [
        (
            "env.csv",
            b"PATH=/usr/bin\x00API_TOKEN=sk-live-abc\x00HOME=/root\x00",
            "line 1 (byte 13)",
        ),
        ("env.dxf", b"0\nSECTION\nAPI_TOKEN=sk-live-abc\x00HOME=/root\n", "line 3 (byte 31)"),
        ("esc.csv", b"x,y\n1,2\n\x1b]0;pwned\x07\x1b[2J,3\n", "line 3 (byte 8)"),
        ("bin.dxf", bytes(range(256)) * 8, "line 1 (byte 0)"),
    ],
)
def test_a_file_of_secrets_escapes_or_bytes_is_named_where_and_never_shown(
    folder, name, content, where
):
    (folder / name).write_bytes(content)
    r = run_capped(folder, _scene(name))
    line = refused(folder, r, name)
    assert f"'{name}': {where} holds a control or NUL character" in line, line
    assert not any(s in r.stderr for s in SECRETS), line
    assert "\\x" not in r.stderr and "\x1b" not in r.stderr, line


def test_a_broken_binary_dxf_is_refused_without_its_bytes(folder):
    """A binary DXF goes to ezdxf (it reads them); its complaint is not shown where it
    would quote bytes."""
    doc = ezdxf.new("R2010")
    doc.modelspace().add_lwpolyline([(0, 0), (1, 0), (1, 1)], close=True)
    doc.saveas(folder / "whole.dxf", fmt="bin")
    data = (folder / "whole.dxf").read_bytes()
    (folder / "whole.dxf").unlink()
    (folder / "ring.dxf").write_bytes(data[: len(data) // 2] + b"\x1b[2J API_TOKEN=sk-live")
    r = run_capped(folder, _scene("ring.dxf"))
    line = refused(folder, r, "ring.dxf")
    assert "'ring.dxf': not a readable DXF file" in line, line
    assert not any(s in r.stderr for s in SECRETS) and "\\x" not in r.stderr, line


def test_a_broken_ascii_stl_of_secrets_is_refused_without_them(folder):
    """A mesh goes to trimesh (binary STL holds any byte): its complaint is bounded and
    left out where it would quote control bytes."""
    (folder / "ring.stl").write_bytes(
        b"solid x\nfacet normal 0 0 1\n outer loop\n  vertex API_TOKEN=sk-live\x00\x1b[2J 0 0\n"
    )
    r = run_capped(folder, _scene("ring.stl"))
    line = refused(folder, r, "ring.stl")
    assert "ring.stl: " in line, line
    assert not any(s in r.stderr for s in SECRETS) and "\\x" not in r.stderr, line
