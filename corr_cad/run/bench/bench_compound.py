"""Benchmark of the whole drive: the prototype with ``[first_stage]`` and every solid format.

``corr-cad bench --study compound``. The target (the compound reducer's
issue): the prototype with its first gear stage and every format runs in
8 s or less. Each run is a fresh ``python -m corr_cad run`` (as a user runs
it), the prototype alone and with the first stage interleaved, so that both
see the same machine load. Reported per run: the wall time, the CPU time
(user + system of the child processes: the STEP pool worker's too), the
STEP stage's seconds (it runs in a pool worker beside the others on two
cores or more) and the sum of the other stages' seconds, from
``manifest.json``. A fourth row runs ``templates/compound.toml`` with
``formats = ["all"]`` where the source tree holds it (its own folder
beside the scene, as a user runs it). Measured, never asserted.
"""

from __future__ import annotations

import json
import os
import statistics
import tempfile
import time
from pathlib import Path

from corr_cad.run.bench.bench_common import _table, _write_csv
from corr_cad.run.bench.bench_speed import PROTOTYPE_SCENE

__all__ = ["compound_speed", "FIRST_STAGE_SCENE"]

#: ``templates/compound.toml``'s first stage (i1 = -5), 22 N*m at the pinion:
#: the prototype's 110 N*m on the crank.
_FIRST_STAGE = """[first_stage]
pinion_teeth = 18
wheel_teeth = 36
crank_gear_teeth = 90
module = 1.5
pressure_angle_deg = 20.0
shift_pinion = 0.5
shift_wheel = 0.0
shift_crank_gear = 0.5
face_width = 15.0
addendum = 1.0
dedendum = 1.25
backlash_allowance = 0.03
"""

#: The prototype's scene with the first stage, every solid format (the
#: prototype's and the other meshes: 3mf, glb, ply) and the torque at the pinion.
FIRST_STAGE_SCENE = _FIRST_STAGE + PROTOTYPE_SCENE.replace(
    '"stl", "step"', '"stl", "3mf", "glb", "ply", "step"'
).replace("input_torque = 1.1e5", "input_torque_Nm = 22.0")


#: The bundled compound template, in the source tree (absent from an installed wheel).
COMPOUND_TEMPLATE = Path(__file__).resolve().parents[3] / "templates" / "compound.toml"


def compound_all_scene() -> str | None:
    """``templates/compound.toml`` with ``formats = ["all"]``, or None where it is not here."""
    if not COMPOUND_TEMPLATE.is_file():
        return None
    lines = COMPOUND_TEMPLATE.read_text(encoding="utf-8").splitlines()
    lines = ['formats = ["all"]' if ln.startswith("formats =") else ln for ln in lines]
    return "\n".join(lines) + "\n"


def _run_once(scene: Path, out: Path, serial: bool) -> list[float]:
    """``[wall s, CPU s, step_files s, other stages s]`` of one fresh run."""
    import resource
    import shutil
    import subprocess
    import sys

    shutil.rmtree(out, ignore_errors=True)
    cmd = [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(out), "--quiet"]
    if serial:
        cmd += ["--executor", "serial"]
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime
    stages = json.loads((out / "manifest.json").read_text(encoding="utf-8"))["stages"]
    step = sum(s["seconds"] for s in stages if s["name"] == "step_files")
    rest = sum(s["seconds"] for s in stages if s["name"] != "step_files")
    return [wall, cpu, step, rest]


def compound_speed(out: Path, quick: bool = False) -> list:
    """Wall and CPU time of the prototype with and without ``[first_stage]``, median."""
    repeat = 1 if quick else 3
    cases = {
        "prototype, its formats": (PROTOTYPE_SCENE, False),
        "prototype + [first_stage], every solid format": (FIRST_STAGE_SCENE, False),
        "prototype + [first_stage], every solid format, --executor serial": (
            FIRST_STAGE_SCENE,
            True,
        ),
    }
    every = compound_all_scene()
    if every is not None:
        cases['templates/compound.toml, formats = ["all"]'] = (every, False)
    runs: dict[str, list[list[float]]] = {label: [] for label in cases}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(repeat):  # interleaved: each case sees the same load
            for label, (text, serial) in cases.items():
                scene = Path(tmp) / "s.toml"
                scene.write_text(text)
                runs[label].append(_run_once(scene, Path(tmp) / "o", serial))
    load = os.getloadavg()[0]
    rows = [
        [label, *(statistics.median(r[i] for r in rs) for i in range(4)), load]
        for label, rs in runs.items()
    ]
    header = ["run", "wall_s", "cpu_s", "step_stage_s", "other_stages_s", "load_avg_1min"]
    _table(f"prototype with [first_stage]: a fresh process, median of {repeat}", header, rows)
    _write_csv(out, "compound_speed.csv", header, rows)
    return rows
