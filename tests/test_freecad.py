"""FreeCAD 0.20 reads corr-cad's STEP assembly (skipped where ``freecadcmd`` is absent).

The reproducer of ``docs/outputs.md`` ("Opening the assembly in FreeCAD"):
two placed instances written by :func:`corr_cad.export.step.write_assembly_step`
open headless with FreeCAD's import preference ``UseLinkGroup`` off, each a
solid of the part's volume; with it on (FreeCAD's default) its importer
crashes, on FreeCAD's own export as well. The same two instances written by
:func:`corr_cad.export.step.write_compound_step` (one compound, the file a
run writes as ``assembly_<angle>deg_freecad.step``) open with its defaults.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

FREECAD = shutil.which("freecadcmd")
pytestmark = [
    pytest.mark.skipif(FREECAD is None, reason="FreeCAD (freecadcmd) not installed"),
    pytest.mark.slow,
]

OPEN = """
import sys, FreeCAD, Import
FreeCAD.ParamGet("User parameter:BaseApp/Preferences/Mod/Import").SetBool(
    "UseLinkGroup", {link_group})
doc = FreeCAD.newDocument("t")
Import.insert({path!r}, doc.Name)
parts = [o for o in doc.Objects if o.TypeId == "Part::Feature"]
print("PARTS", sorted(o.Label for o in parts), [round(o.Shape.Volume, 6) for o in parts])
"""


def _two_boxes(path: Path) -> None:
    pytest.importorskip("OCP")
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox

    from corr_cad.export.step import write_assembly_step
    from corr_cad.geometry.placement import Placement

    box = BRepPrimAPI_MakeBox(10.0, 10.0, 10.0).Shape()
    placements = [
        Placement("b1", "box", 0.0, np.zeros(3), np.zeros(2)),
        Placement("b2", "box", 0.3, np.array([20.0, 0.0, 0.0]), np.zeros(2)),
    ]
    write_assembly_step({"box": box}, {"box": "box"}, placements, path, "asm")


def _freecad(tmp_path: Path, step: Path, link_group: bool) -> subprocess.CompletedProcess:
    script = tmp_path / "open.py"
    script.write_text(OPEN.format(link_group=link_group, path=str(step)))
    home = tmp_path / "home"  # FreeCAD keeps its preferences there: a fresh set each run
    home.mkdir(exist_ok=True)
    env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "HOME": str(home)}
    return subprocess.run(
        [FREECAD, str(script)], capture_output=True, text=True, env=env, timeout=600
    )


def test_the_assembly_opens_headless_with_link_groups_off(tmp_path):
    _two_boxes(tmp_path / "two.step")
    r = _freecad(tmp_path, tmp_path / "two.step", link_group=False)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    line = next(ln for ln in r.stdout.splitlines() if ln.startswith("PARTS"))
    assert line == "PARTS ['box', 'box001'] [1000.0, 1000.0]"


def test_freecad_s_default_importer_crashes_on_two_instances(tmp_path):
    """The fault the manual names: FreeCAD 0.20's headless importer, not the file.
    A FreeCAD that no longer crashes passes this test too (it then opens both)."""
    _two_boxes(tmp_path / "two.step")
    r = _freecad(tmp_path, tmp_path / "two.step", link_group=True)
    if r.returncode != 0:  # FreeCAD's handler prints the signal and a backtrace
        out = r.stdout + r.stderr
        assert "SIGSEGV" in out or "Segmentation fault" in out or r.returncode == -11, out[-2000:]


def test_the_freecad_variant_opens_with_freecad_s_defaults(tmp_path):
    pytest.importorskip("OCP")
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox

    from corr_cad.export.step import write_compound_step
    from corr_cad.geometry.placement import Placement

    box = BRepPrimAPI_MakeBox(10.0, 10.0, 10.0).Shape()
    placements = [
        Placement("b1", "box", 0.0, np.zeros(3), np.zeros(2)),
        Placement("b2", "box", 0.3, np.array([20.0, 0.0, 0.0]), np.zeros(2)),
    ]
    step = write_compound_step({"box": box}, placements, tmp_path / "c.step", "asm")
    script = tmp_path / "default.py"  # no preference set: FreeCAD's defaults
    script.write_text(
        OPEN.split("FreeCAD.ParamGet")[0] + OPEN.split("{link_group})")[1].format(path=str(step))
    )
    home = tmp_path / "home"
    home.mkdir()
    env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "HOME": str(home)}
    r = subprocess.run([FREECAD, str(script)], capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    line = next(ln for ln in r.stdout.splitlines() if ln.startswith("PARTS"))
    # Each instance its own solid (FreeCAD names them Solid, Solid001), and the compound.
    assert line == "PARTS ['Solid', 'Solid001'] [1000.0, 1000.0]"
