"""What a user of the drive reads: the console, ``manifest.json``, ``forces.png`` and the
report show the heavier row (and the other, named), never row A alone.

Row A's rollers 1 um small, row B nominal: row B carries about 58 % of the crank
moment. The real CLI in a subprocess; the console's peak force, pressure and loaded
rollers are compared with ``forces_summary.json``'s heavier row.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

SCENE = """[load]
input_torque = 1.1e5
[export]
formats = ['forces', 'report', 'interference']
interference_method = 'exact'
interference_positions = 360
[solver]
model = "drive"
positions = 52
[errors]
roller_radius_error = -0.001
[errors.row_b]
roller_radius_error = 0.0
[bearings.eccentric]
needles = 40
needle_diameter = 6.0
needle_length = 12.0
"""


@pytest.fixture(scope="module")
def asym(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("rows")
    (tmp / "s.toml").write_text(SCENE)
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(tmp / "s.toml"), "--out", str(tmp / "o")],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert r.returncode == 0, r.stderr
    return tmp / "o", r.stdout


def _peaks(stdout: str, head: str) -> dict:
    force = next(ln for ln in stdout.splitlines() if ln.startswith(f"{head}: peak F_n"))
    press = next(ln for ln in stdout.splitlines() if ln.startswith(f"{head}: peak contact"))
    fn = re.search(r"peak F_n ([0-9.]+) N on roller (\d+)", force)
    p = re.search(r"pressure ([0-9]+) MPa .*loaded rollers (\d+)-(\d+)", press)
    return {
        "F_n": float(fn.group(1)),
        "roller": int(fn.group(2)),
        "pressure": float(p.group(1)),
        "loaded": (int(p.group(2)), int(p.group(3))),
    }


def test_console_peaks_are_the_heavier_rows_of_forces_summary(asym):
    out, stdout = asym
    s = json.loads((out / "forces_summary.json").read_text())
    h = s["heavier_row"]
    rows = s["rows"]
    assert h == "B"  # row A's rollers are small: row B carries more
    assert rows["B"]["share"]["mean"] > 0.55 > 0.45 > rows["A"]["share"]["mean"]
    assert rows["B"]["peak"]["F_n"]["value"] > rows["A"]["peak"]["F_n"]["value"]
    for name in ("A", "B"):
        tag = f"row {name}, the heavier" if name == h else f"row {name}"
        got = _peaks(stdout, f"drive ({tag})")
        pk = rows[name]["peak"]
        assert got["F_n"] == round(pk["F_n"]["value"], 1)
        assert got["roller"] == pk["F_n"]["roller"]
        assert got["pressure"] == round(pk["pressure"]["value"])
        assert got["loaded"] == (pk["loaded_rollers"]["min"], pk["loaded_rollers"]["max"])
    # the heavier row is printed first, and no line reports a peak without naming its row
    first = next(ln for ln in stdout.splitlines() if "peak F_n" in ln)
    assert first.startswith("drive (row B, the heavier)")
    assert not [ln for ln in stdout.splitlines() if ln.startswith("drive: peak")]
    assert f"row {h} roller 1: F_j mean {rows[h]['F_j_mean']:.1f} N" in stdout


def test_manifest_and_report_carry_the_heavier_row(asym):
    out, _ = asym
    s = json.loads((out / "forces_summary.json").read_text())
    m = json.loads((out / "manifest.json").read_text())["forces"]
    h = s["heavier_row"]
    assert m["heavier_row"] == h
    assert m["peak"] == s["rows"][h]["peak"]
    assert m["F_n_peak"] == s["rows"][h]["F_n_peak"]
    assert m["rows"] == s["rows"]  # both rows, as forces_summary.json gives them
    html = (out / "report.html").read_text()
    assert f"the drive's row {h}, the heavier of its two rows" in html


def test_the_heavier_row_is_chosen_by_the_peak_gear_force():
    """Unit: equal peaks (identical rows) fall to row A; otherwise the larger F_n."""
    from types import SimpleNamespace

    import numpy as np

    from corr_cad.run.stages.stages_drive import heavier_row

    def res(a, b, share):
        rows = [SimpleNamespace(F_n=np.array([[a]])), SimpleNamespace(F_n=np.array([[b]]))]
        return SimpleNamespace(rows=rows, row_a_share=np.array([share]))

    assert heavier_row(res(1.0, 2.0, 0.5)) == 1
    assert heavier_row(res(2.0, 1.0, 0.5)) == 0
    assert heavier_row(res(1.0, 1.0 + 1e-13, 0.5 - 1e-17)) == 0  # a tie: row A
    assert heavier_row(res(1.0, 1.0, 0.4)) == 1  # same peak, row B carries more


def test_the_drives_clearance_has_both_rows_and_the_bearings_free_play(asym):
    """Row A's rollers 1 um small open 1 um at every contact of row A; row B is exact;
    the bearings' free play (Pd / 2) and the drive's free rotation are stated."""
    import csv

    out, stdout = asym
    c = json.loads((out / "manifest.json").read_text())["clearance"]
    assert c["positions"] == 360 and set(c["rows"]) == {"A", "B"}
    a, b = c["rows"]["A"], c["rows"]["B"]
    for contact in ("cam", "ring", "slot"):
        assert a[contact]["min_mm"] == pytest.approx(0.001, abs=1e-9)
        assert abs(b[contact]["min_mm"]) <= 1e-9
    assert c["min_clearance_mm"] == min(a["min_clearance_mm"], b["min_clearance_mm"])
    assert c["bearing_free_play_mm"] == {"A": 0.0, "B": 0.0}  # 40 needles, Pd = 0
    forces = json.loads((out / "forces_summary.json").read_text())
    assert c["drive_backlash_arcmin"]["source"].startswith("forces")
    with open(out / "clearance.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert {r["row"] for r in rows} == {"A", "B"} and len(rows) == 2 * 360 * 26
    assert "clearance over 360 crank positions of both rows" in stdout
    assert "each cam moves 0 um on its needles" in stdout
    assert forces["heavier_row"] == "B"
