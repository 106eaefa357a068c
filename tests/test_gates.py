"""Gates that gate, a console that tells the truth, inputs that cannot be NaN.

Everything runs the real CLI in a subprocess on a folder holding other files,
and checks the printed numbers against the CSV files read back here.
"""

from __future__ import annotations

import csv
import json
import math
import re
import subprocess
import sys

import numpy as np
import pytest

from corr_cad.errors import SceneError
from corr_cad.run.scene.scene import SCHEMA, parse_scene


def run(scene_text, tmp_path, *extra, name="s"):
    folder = tmp_path / name
    folder.mkdir(exist_ok=True)
    (folder / "notes.txt").write_text("someone else's file\n")
    scene = folder / f"{name}.toml"
    scene.write_text(scene_text)
    out = folder / "out"
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(out), *extra],
        capture_output=True,
        text=True,
        cwd=folder,
    )
    return r, out


MC = """
[export]
formats = ["forces", "montecarlo"]
[load]
input_torque = 1.1e5
[solver]
positions = 260
[tolerances]
cam_radius = { uniform = 0.01 }
[montecarlo]
samples = 16
positions = 26
seed = 3
[checks]
max_gear_force = 5000.0
"""


@pytest.fixture(scope="module")
def mc_runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("gate")
    ungated = run(MC, tmp, "--executor", "serial", name="ungated")
    gated = run(MC + "max_failure_probability = 0.05\n", tmp, "--executor", "serial", name="gated")
    return ungated, gated


@pytest.mark.slow
def test_without_max_failure_probability_only_the_nominal_design_is_gated(mc_runs):
    (r, out), _ = mc_runs
    assert r.returncode == 0, r.stderr
    m = json.loads((out / "manifest.json").read_text())
    assert m["checks"]["max_gear_force"]["passed"] is True
    assert "montecarlo" not in m["checks"]
    assert m["montecarlo"]["failure_probability"]["max_gear_force"] > 0.05


@pytest.mark.slow
def test_failing_montecarlo_gate_exits_1_and_names_limit_and_probability(mc_runs):
    _, (r, out) = mc_runs
    assert r.returncode == 1
    rows = list(csv.DictReader((out / "montecarlo.csv").open()))
    prob = np.mean([float(x["peak_gear_force"]) > 5000.0 for x in rows])
    assert 0.05 < prob < 1
    m = json.loads((out / "manifest.json").read_text())
    gate = m["checks"]["montecarlo"]["max_gear_force"]
    assert gate == {"probability": pytest.approx(prob), "allowed": 0.05, "passed": False}
    # stderr also carries the progress lines (rate, time left); the verdict is one line.
    errors = [x for x in r.stderr.splitlines() if x.startswith("corr-cad: check failed")]
    assert len(errors) == 1
    line = errors[0]
    assert "montecarlo max_gear_force" in line
    assert f"{prob:.4g}" in line and "0.05" in line
    assert "check montecarlo max_gear_force: FAIL" in r.stdout


@pytest.mark.slow
def test_passing_gate_exits_0(tmp_path):
    r, out = run(MC + "max_failure_probability = 1.0\n", tmp_path, "--executor", "serial")
    assert r.returncode == 0, r.stderr
    gate = json.loads((out / "manifest.json").read_text())["checks"]["montecarlo"]
    assert gate["max_gear_force"]["passed"] is True


@pytest.mark.parametrize(
    "value, needle",
    [
        ("1.5", "[checks] max_failure_probability = 1.5: allowed range is"),
        ("-0.1", "[checks] max_failure_probability = -0.1: allowed range is [0, 1]"),
        ("nan", "[checks] max_failure_probability = nan: must be a finite number"),
    ],
)
def test_bad_max_failure_probability(tmp_path, value, needle):
    r, out = run(MC + f"max_failure_probability = {value}\n", tmp_path)
    assert r.returncode == 2 and needle in r.stderr and not out.exists()
    assert "Traceback" not in r.stderr


def test_max_failure_probability_needs_montecarlo(tmp_path):
    text = MC.replace('"forces", "montecarlo"', '"forces"') + "max_failure_probability = 0.1\n"
    r, out = run(text, tmp_path)
    assert r.returncode == 2 and "add 'montecarlo'" in r.stderr and not out.exists()


# --- the console ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def forces_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("console")
    r, out = run(
        '[export]\nformats = ["forces"]\n[load]\ninput_torque = 1.1e5\n'
        "[solver]\npositions = 260\n[errors]\neccentricity_error = 0.004\n"
        "roller_radius_errors = ["
        + ", ".join(f"{0.001 * math.sin(i):.6f}" for i in range(26))
        + "]\n",
        tmp,
    )
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader((out / "forces.csv").open()))
    return r.stdout, rows, json.loads((out / "manifest.json").read_text())


def _num(pattern, text):
    return re.search(pattern, text).groups()


def test_console_prints_the_drives_peaks_with_roller_and_angle(forces_run):
    stdout, rows, m = forces_run
    for col, label in (("F_n", "F_n"), ("F_j", "F_j")):
        top = max(rows, key=lambda x: float(x[col]))
        v, roller, ang = _num(
            rf"peak {label} ([\d.]+) N on roller (\d+) at crank angle ([\d.]+)", stdout
        )
        assert float(v) == pytest.approx(float(top[col]), abs=0.06)
        assert int(roller) == int(top["roller"]) and int(roller) != 1
        assert float(ang) == pytest.approx(float(top["crank_angle_deg"]), abs=0.006)
    top = max(rows, key=lambda x: abs(float(x["F_s"])))
    v, roller, _ = _num(r"peak \|F_s\| ([\d.]+) N on roller (\d+) at crank angle ([\d.]+)", stdout)
    assert float(v) == pytest.approx(abs(float(top["F_s"])), abs=0.06)
    contact, col = max(
        ((c, float(x[f"p_{c}"])) for x in rows for c in ("cam", "slot", "gear")),
        key=lambda cv: cv[1],
    )
    p, c, roller, ang = _num(
        r"peak contact pressure (\d+) MPa at the (\w+) contact, "
        r"roller (\d+) at crank angle ([\d.]+)",
        stdout,
    )
    assert float(p) == pytest.approx(col, abs=0.6) and c == contact
    loaded = {}
    for x in rows:
        loaded.setdefault(x["crank_angle_deg"], 0)
        loaded[x["crank_angle_deg"]] += float(x["F_j"]) > 0
    lo, hi = _num(r"loaded rollers (\d+)-(\d+)", stdout)
    assert (int(lo), int(hi)) == (min(loaded.values()), max(loaded.values()))
    assert m["forces"]["peak"]["F_n"]["roller"] == int(
        max(rows, key=lambda x: float(x["F_n"]))["roller"]
    )


def test_console_roller_1_line_is_roller_1(forces_run):
    stdout, rows, _ = forces_run
    one = [x for x in rows if x["roller"] == "1"]
    line = next(x for x in stdout.splitlines() if x.startswith("roller 1:"))
    assert "MPa" not in line  # the drive's pressure peak is not roller 1's
    fn_peak = float(_num(r"F_n mean [\d.]+ N, peak ([\d.]+) N", line)[0])
    assert fn_peak == pytest.approx(max(float(x["F_n"]) for x in one), abs=0.06)
    loaded = [float(x["F_j"]) for x in one if float(x["F_j"]) > 0]
    mean = float(_num(r"F_j mean ([\d.]+) N", line)[0])
    assert mean == pytest.approx(np.mean(loaded), abs=0.06)


def test_knife_edge_tooth_tip_warns(tmp_path):
    # z = 39, Rj = 150, e = 3, r = 5.35: tip radius 0.02 mm (limit 5.371).
    r, _ = run(
        "[design]\ntooth_count = 39\ncam_radius = 150.0\neccentricity = 3.0\n"
        'roller_radius = 5.35\n[export]\nformats = ["forces"]\n'
        "[load]\ninput_torque = 3e5\n[solver]\npositions = 400\n",
        tmp_path,
    )
    assert r.returncode == 0, r.stderr
    assert re.search(r"warning: geometry: tooth tip radius 0.0197 mm is below 0.1 mm", r.stdout)
    assert "below the largest gear contact half-width" in r.stdout
    assert re.search(r"peak contact pressure \d+ MPa at the gear contact", r.stdout)
    assert "warning: material: peak contact pressure" in r.stdout


@pytest.mark.slow
def test_montecarlo_gigapascal_pressures_carry_a_validity_warning(tmp_path):
    text = MC.replace("uniform = 0.01", "uniform = 0.05")
    r, out = run(text, tmp_path, "--executor", "serial")
    m = json.loads((out / "manifest.json").read_text())
    p99 = m["montecarlo"]["percentiles"]["peak_pressure"]["p99"]
    assert p99 > 4000
    assert re.search(
        r"warning: validity: Monte Carlo peak pressure p\d+ = \d+ MPa exceeds 4000", r.stdout
    )


def test_nominal_prototype_prints_no_warning(tmp_path):
    r, _ = run(
        '[export]\nformats = ["forces"]\n[load]\ninput_torque = 1.1e5\n[solver]\npositions = 52\n',
        tmp_path,
    )
    assert r.returncode == 0 and "warning" not in r.stdout


# --- NaN and inf rejected for every float key of the schema --------------------------


def _float_keys():
    for section, keys in SCHEMA.items():
        for key, spec in keys.items():
            if spec.kind in ("float", "list[float]", "list[list[float]]", "distribution"):
                yield section, key, spec.kind


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("section, key, kind", list(_float_keys()))
def test_non_finite_rejected_for_every_float_key(section, key, kind, bad):
    value = {
        "float": bad,
        "list[float]": [0.0] * 25 + [bad],
        "list[list[float]]": [[3.0, 0.001, bad]],
        "distribution": {"normal": bad},
    }[kind]
    with pytest.raises(SceneError, match=re.escape(f"[{section}] {key}")):
        parse_scene({section: {key: value}})


def test_non_finite_through_the_cli(tmp_path):
    r, out = run("[errors]\neccentricity_error = nan\n", tmp_path)
    assert r.returncode == 2 and not out.exists()
    assert r.stderr.strip() == (
        "corr-cad: error: [errors] eccentricity_error = nan: must be a finite number, e.g. 0"
    )


# --- a writer killed inside the write leaves the previous file ----------------------

KILL = r"""
import builtins, io, os, signal, sys
from pathlib import Path
from corr_cad import GearDesign
from corr_cad.export import dxf
from corr_cad.export.files import write_json

target = Path(sys.argv[2])
which = sys.argv[1]


class Killer:
    # A file whose first write puts out a few bytes, then the process is killed.
    def __init__(self, f):
        self.f = f

    def write(self, data):
        self.f.write(data[:100])
        self.f.flush()
        os.kill(os.getpid(), signal.SIGKILL)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return self.f.__exit__(*exc)

    def __getattr__(self, k):
        return getattr(self.f, k)


def wrap(orig):
    def opener(file, mode="r", *a, **k):
        f = orig(file, mode, *a, **k)
        return Killer(f) if any(c in mode for c in "wax") else f
    return opener


builtins.open = io.open = wrap(io.open)
_fdopen = os.fdopen
os.fdopen = lambda fd, mode="r", *a, **k: Killer(_fdopen(fd, mode, *a, **k))
d = GearDesign(roller_radius=7.0)
{"roller": lambda: dxf.write_roller(d, target),
 "disk_cam": lambda: dxf.write_disk_cam(d, target),
 "teeth_frame": lambda: dxf.write_teeth_frame(d, target),
 "json": lambda: write_json(target, {"a": 1})}[which]()
"""


def test_fallback_of_the_new_file_writer_never_overwrites(tmp_path, monkeypatch):
    """Without hard links (EPERM) write_new_text creates the file exclusively: an existing
    file is refused with FileExistsError and keeps its bytes; a new one is written."""
    import errno

    from corr_cad.export import files

    def no_links(*a, **k):
        raise OSError(errno.EPERM, "hard links not permitted")

    monkeypatch.setattr(files.os, "link", no_links)
    kept = tmp_path / "modified.toml"
    kept.write_text("the user's own\n")
    with pytest.raises(FileExistsError):
        files.write_new_text(kept, "written over\n")
    assert kept.read_text() == "the user's own\n"
    fresh = files.write_new_text(tmp_path / "new.toml", "made\n")
    assert fresh.read_text() == "made\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["modified.toml", "new.toml"]


@pytest.mark.parametrize("which", ["roller", "disk_cam", "teeth_frame", "json"])
def test_writer_killed_inside_the_write_leaves_the_previous_file(tmp_path, which):
    from corr_cad import GearDesign
    from corr_cad.export import dxf
    from corr_cad.export.files import write_json

    target = tmp_path / ("x.json" if which == "json" else f"{which}.dxf")
    d = GearDesign()
    {
        "roller": lambda: dxf.write_roller(d, target),
        "disk_cam": lambda: dxf.write_disk_cam(d, target),
        "teeth_frame": lambda: dxf.write_teeth_frame(d, target),
        "json": lambda: write_json(target, {"previous": True}),
    }[which]()
    before = target.read_bytes()
    script = tmp_path / "kill.py"
    script.write_text(KILL)
    r = subprocess.run([sys.executable, str(script), which, str(target)], capture_output=True)
    assert r.returncode == -9  # killed inside the write
    assert target.read_bytes() == before
