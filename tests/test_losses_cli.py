"""``[lubrication]``, ``[thermal]`` and ``[thermal.test]`` as a user runs them.

Thermal: the paper's no-load programme (0 to 2,000 r/min, then held) gives a
curve that rises and settles, and its settled temperature equals the hand
heat balance ``sum_b Z_b M0_b(nu(T), k_b n) omega_b = h A (T - T_amb)``
evaluated in this test (Palmgren by hand, Walther by hand). Bytes: the
figures and files of a scene without ``[lubrication]`` are those it has with
it, less the added keys and files.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

DESIGN = """[design]
tooth_count = 25
cam_radius = 135.0
roller_radius = 8.0
roller_length = 12.0
eccentricity = 3.5
[export]
formats = ["datasheet", "report"]
[load]
input_torque = 1.1e5
[friction]
positions_per_mesh = 2
efficiency_torques = [0.1, 0.5, 1.0]
efficiency_speeds_rpm = [500, 2000]
"""

LUBRICATION = """[lubrication]
iso_vg = 68
map_temperatures_C = [10, 40, 80]
"""

THERMAL = """[thermal]
housing_area_m2 = 0.3
heat_transfer_W_per_m2K = 18.0
heat_capacity_J_per_K = 40000.0
ambient_C = 20.0
[thermal.test]
time_min = [0.0, 10.0, 1500.0]
input_speed_rpm = [0.0, 2000.0, 2000.0]
step_min = 10.0
"""


def _run(tmp_path: Path, text: str, name: str = "s"):
    scene = tmp_path / f"{name}.toml"
    scene.write_text(text)
    out = tmp_path / f"out_{name}"
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(out), "--quiet"],
        capture_output=True,
        text=True,
    )
    return r, out


def _walther(t: float) -> float:
    """ISO VG 68 (nu_40 = 68, nu_100 = 8.53) at t C, ASTM D341 written out."""
    w40 = math.log10(math.log10(68.0 + 0.7))
    w100 = math.log10(math.log10(8.53 + 0.7))
    b = (w40 - w100) / (math.log10(373.15) - math.log10(313.15))
    a = w40 + b * math.log10(313.15)
    return 10 ** (10 ** (a - b * math.log10(t + 273.15))) - 0.7


def _hand_loss_W(bearings: list, crank_rpm: float, t: float) -> float:
    total = 0.0
    for b in bearings:
        n = b["speed_per_crank"] * crank_rpm
        vn = _walther(t) * n
        m0 = (
            b["f0"] * b["pitch_diameter_mm"] ** 3 * (1e-7 * vn ** (2 / 3) if vn >= 2000 else 160e-7)
        )
        total += b["count"] * m0 * 1e-3 * n * 2 * math.pi / 60
    return total


@pytest.fixture(scope="module")
def thermal_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("thermal")
    r, out = _run(tmp, DESIGN + LUBRICATION + THERMAL)
    assert r.returncode == 0, r.stderr
    return r, out, json.loads((out / "datasheet.json").read_text())


@pytest.mark.slow
def test_thermal_no_load_programme_rises_settles_and_meets_hand_balance(thermal_run):
    _, out, d = thermal_run
    rows = (out / "temperature.csv").read_text().splitlines()
    assert rows[0] == "time_min,input_speed_rpm,output_torque_Nm,oil_temperature_C,loss_W"
    temps = [float(r.split(",")[3]) for r in rows[1:]]
    assert temps[0] == 20.0
    assert all(b >= a for a, b in zip(temps, temps[1:], strict=False))  # rises
    assert temps[-1] - temps[-2] < 1e-6  # and settles
    assert temps[3] - temps[0] > 0.5 * (temps[-1] - temps[0])  # most of it in 30 min
    bearings = d["load_independent_losses"]["bearings"]
    hA = 0.3 * 18.0
    lo, hi = 20.0, 400.0
    for _ in range(200):  # bisection of the hand balance
        mid = 0.5 * (lo + hi)
        if _hand_loss_W(bearings, 2000.0, mid) > hA * (mid - 20.0):
            lo = mid
        else:
            hi = mid
    assert temps[-1] == pytest.approx(lo, abs=1e-6)
    assert d["thermal"]["steady_temperature_C"]["no_load"][1] == pytest.approx(lo, abs=1e-6)
    assert d["thermal"]["time_constant_min"] == pytest.approx(40000.0 / hA / 60.0)
    png = out / "temperature.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_total_efficiency_falls_at_low_torque_high_speed_cold_oil(thermal_run):
    _, _, d = thermal_run
    e = d["efficiency_total"]
    fwd = e["forward"]  # [temperature][speed][torque]
    assert e["temperatures_C"] == [10.0, 40.0, 80.0]
    for plane in fwd:
        for row in plane:
            assert all(b > a for a, b in zip(row, row[1:], strict=False))  # low torque: lower
        assert all(b < a for a, b in zip(plane[0], plane[1], strict=True))  # high speed: lower
    for k in range(2):
        assert all(c > w for w, c in zip(fwd[k][1], fwd[k + 1][1], strict=True))  # cold: lower
    assert 0.0 < e["forward_min"] < e["forward_max"] <= 1.0
    # the friction model's forward efficiency bounds the total at every point
    assert e["forward_max"] < d["efficiency_forward"]["max"]
    st = d["starting_torque_total_Nm"]
    assert st["preload_friction_at_crank"] == 0.0 and st["at_crank"] > 0.0  # no preload
    assert st["backdriving_at_output"] == pytest.approx(26 * st["at_crank"])
    m = d["modified_life"]["bearing_row1"]
    assert m["L10m_h"] == pytest.approx(m["a_ISO"] * m["L10_h"])
    assert m["L10_h"] == pytest.approx(d["life_h"]["bearing_row1"])


@pytest.mark.slow
def test_bytes_without_lubrication_are_the_same(tmp_path, thermal_run):
    """The hook adds keys and files; everything a scene without [lubrication] writes
    is written the same with it, and a scene without it has none of the new keys."""
    _, out_with, with_ = thermal_run
    r, out = _run(tmp_path, DESIGN, "plain")
    assert r.returncode == 0, r.stderr
    without = json.loads((out / "datasheet.json").read_text())
    added = {
        "lubrication",
        "load_independent_losses",
        "efficiency_total",
        "starting_torque_total_Nm",
        "modified_life",
        "thermal",
        "thermal_test",
    }
    assert not added & set(without)
    assert added <= set(with_)
    assert {k: v for k, v in with_.items() if k not in added} == without
    for name in ("efficiency.csv", "life.csv", "windup.csv", "hysteresis.csv"):
        assert (out / name).read_bytes() == (out_with / name).read_bytes(), name
    assert not (out / "temperature.csv").exists()
    inputs = json.loads((out / "manifest.json").read_text())
    assert "lubrication" not in json.dumps(inputs.get("inputs", inputs.get("scene", {})))


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ("[lubrication]\niso_vg = 69\n", "[lubrication] iso_vg = 69: one of the ISO 3448"),
        (
            "[lubrication]\niso_vg = 68\nviscosity_40C = 68.0\n",
            "[lubrication] give iso_vg or viscosity_40C with viscosity_100C, not both",
        ),
        ('[lubrication]\nlubricant = "oil"\n', "[lubrication] needs iso_vg (e.g. 68)"),
        (
            "[lubrication]\nviscosity_40C = 8.0\nviscosity_100C = 9.0\n",
            "[lubrication] viscosity_100C = 9.0: allowed range is [2, viscosity_40C = 8)",
        ),
        ("[thermal]\n", "[thermal] needs [lubrication]"),
        (
            LUBRICATION + "[thermal]\n[thermal.test]\ntime_min = [0, 10]\ninput_speed_rpm = [0]\n",
            "[thermal.test] input_speed_rpm = [0.0]: 1 values; time_min has 2",
        ),
        (
            LUBRICATION + "[thermal]\n[thermal.test]\ntime_min = [0, 10, 5]\n"
            "input_speed_rpm = [0, 1, 2]\n",
            "[thermal.test] time_min = [0.0, 10.0, 5.0]: must start at 0 and increase strictly",
        ),
        (
            LUBRICATION + "[thermal]\n[thermal.test]\ninput_speed_rpm = [0, 1]\n",
            "[thermal.test] needs time_min and input_speed_rpm",
        ),
    ],
)
def test_bad_lubrication_and_thermal_refused_in_one_line(tmp_path, extra, message):
    r, out = _run(tmp_path, DESIGN + extra)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], r.stderr
    assert "Traceback" not in r.stderr and not out.exists()


def test_new_writes_the_sections_commented(tmp_path):
    path = tmp_path / "new.toml"
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "new", str(path)], capture_output=True, text=True
    )
    assert r.returncode == 0, r.stderr
    text = path.read_text()
    for line in ("# [lubrication]", "# iso_vg = 68", "# [thermal]", "# [thermal.test]"):
        assert line in text.splitlines()


@pytest.mark.slow
def test_no_load_template_with_first_stage(tmp_path):
    """The paper's no-load test as bundled: the programme's speed is the pinion's (i1 = 5),
    the first stage's wheel and crank bearings drag at their own speeds (Palmgren by hand)."""
    scene = ROOT / "templates" / "no_load_temperature.toml"
    out = tmp_path / "out"
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(out), "--quiet"],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    d = json.loads((out / "datasheet.json").read_text())
    li = d["load_independent_losses"]
    by_name = {b["name"]: b for b in li["bearings"]}
    assert by_name["first_stage_wheel_bearings"]["speed_per_crank"] == pytest.approx(5 * 18 / 36)
    assert by_name["crank_bearings"]["speed_per_crank"] == 1.0
    nu = _walther(40.0)
    for k, n in enumerate(li["input_speed_rpm"]):
        b = by_name["crank_bearings"]
        m0 = 2 * 1e-7 * b["f0"] * (nu * n) ** (2 / 3) * b["pitch_diameter_mm"] ** 3
        assert li["by_element_torque_at_crank_Nm"]["crank_bearings"][k] == pytest.approx(m0 / 1e3)
    st = d["starting_torque_total_Nm"]
    assert st["at_input"] == pytest.approx(st["at_crank"] / 5)
    assert d["thermal_test"]["input_speed_of"] == "the pinion"
    rows = [ln.split(",") for ln in (out / "temperature.csv").read_text().splitlines()[1:]]
    assert [float(r[0]) for r in rows] == [10.0 * i for i in range(19)]  # every 10 min
    # at 2,000 r/min at the pinion the crank turns at 400 r/min: the loss at the end is the
    # hand loss at 400 r/min at the final temperature
    t_end = float(rows[-1][3])
    assert float(rows[-1][4]) == pytest.approx(_hand_loss_W(li["bearings"], 400.0, t_end), rel=1e-5)


@pytest.mark.slow
def test_first_stage_churning_by_hand_in_the_drag_and_the_efficiency(tmp_path):
    """[lubrication] immersion_depth_mm: one wheel of the first stage churns (Changenet &
    Velex, first regime here), its torque by hand at each speed; it lowers the total
    efficiency and leaves the starting torque (no churning at standstill)."""
    text = (ROOT / "templates" / "no_load_temperature.toml").read_text()
    outs = {}
    for h in (0.0, 10.0):
        scene = tmp_path / f"h{h:g}.toml"
        scene.write_text(
            text.replace(
                "temperature_C = 40.0\n", f"temperature_C = 40.0\nimmersion_depth_mm = {h}\n", 1
            )
        )
        r = subprocess.run(
            [
                sys.executable,
                "-m",
                "corr_cad",
                "run",
                str(scene),
                "--out",
                str(tmp_path / f"o{h:g}"),
                "--quiet",
            ],
            capture_output=True,
            text=True,
        )
        assert r.returncode == 0, r.stderr
        outs[h] = json.loads((tmp_path / f"o{h:g}" / "datasheet.json").read_text())
    li = outs[10.0]["load_independent_losses"]
    assert "churning" not in outs[0.0]["load_independent_losses"]
    g = li["churning"][0]
    assert g["speed_per_crank"] == pytest.approx(5 * 18 / 36) and g["pitch_radius_mm"] == 27.0
    nu, r, b, h, v0 = _walther(40.0) * 1e-6, 0.027, 0.015, 0.010, 1e-3
    theta = math.acos(1 - h / r)
    s_m = r * r * (2 * theta - math.sin(2 * theta)) + 2 * r * b * theta
    for k, n in enumerate(li["input_speed_rpm"]):
        w = 2.5 * n * math.pi / 30  # the wheel's speed
        assert w * r * b / nu < 6000  # Changenet & Velex's first regime
        fr, re = w * w * r / 9.80665, w * r * r / nu
        cm = 1.366 * (h / (2 * r)) ** 0.45 * (v0 / (2 * r) ** 3) ** 0.1 * fr**-0.6 * re**-0.21
        t = 0.5 * 870.0 * w * w * s_m * r**3 * cm  # N*m at the wheel
        got = li["by_element_torque_at_crank_Nm"]["first_stage_churning"][k]
        assert got == pytest.approx(2.5 * t, rel=1e-9)
    a, c = outs[0.0], outs[10.0]
    assert c["efficiency_total"]["forward_min"] < a["efficiency_total"]["forward_min"]
    assert c["starting_torque_total_Nm"] == a["starting_torque_total_Nm"]


def test_sections_without_the_datasheet_warn(tmp_path):
    text = DESIGN.replace('formats = ["datasheet", "report"]', 'formats = ["dxf"]')
    text = text.split("[load]")[0]
    text += LUBRICATION + "[thermal]\n"
    scene = tmp_path / "w.toml"
    scene.write_text(text)
    from corr_cad.run.scene.scene import load_scene

    warnings = load_scene(scene).warnings
    for section in ("[lubrication]", "[thermal]"):
        assert f'{section} has no effect in this scene: formats does not list "datasheet"' in (
            warnings
        )


@pytest.mark.slow
def test_datasheet_html_holds_the_new_figures_of_datasheet_json(thermal_run):
    import re

    _, out, d = thermal_run
    html = (out / "datasheet.html").read_text()
    cells = dict(re.findall(r'data-key="([\w.]+)" data-value="([^"]+)"', html))
    for key in (
        "efficiency_total.forward_min",
        "starting_torque_total_Nm.at_input",
        "modified_life.bearing_row1.L10m_h",
        "thermal_test.final_temperature_C",
    ):
        value = d
        for part in key.split("."):
            value = value[part]
        assert float(cells[key]) == value, key
    report = (out / "report.html").read_text()
    for label in ("efficiency, total", "drag torque at the crank", "L10m bearing_row1"):
        assert f"<td>{label}</td>" in report, label
    assert "temperature test, final" in report


@pytest.mark.slow
def test_duty_cycle_with_output_torque_heats_by_both_losses(tmp_path):
    """A loaded programme: each row's loss is the drag at its temperature plus the Coulomb
    losses ``P_out (1 / eta - 1)`` at the torque, with ``eta`` from efficiency.csv."""
    programme = (
        "[thermal]\n[thermal.test]\ntime_min = [0.0, 30.0]\ninput_speed_rpm = [1000.0, 1000.0]\n"
        "output_torque_Nm = [1430.0, 1430.0]\nstep_min = 5.0\n"
    )
    r, out = _run(tmp_path, DESIGN + LUBRICATION + programme, "duty")
    assert r.returncode == 0, r.stderr
    d = json.loads((out / "datasheet.json").read_text())
    eff = [ln.split(",") for ln in (out / "efficiency.csv").read_text().splitlines()[1:]]
    eta = next(float(x[3]) for x in eff if float(x[2]) == 0.5)
    p_out = 1430.0 * 1000.0 * 2 * math.pi / 60 / 26
    rows = [ln.split(",") for ln in (out / "temperature.csv").read_text().splitlines()[1:]]
    assert len(rows) == 7
    for row in rows:
        t, loss = float(row[3]), float(row[4])
        drag = _hand_loss_W(d["load_independent_losses"]["bearings"], 1000.0, t)
        assert loss == pytest.approx(drag + p_out * (1 / eta - 1), rel=1e-5)
        assert float(row[2]) == 1430.0
    temps = [float(r[3]) for r in rows]
    assert all(b > a for a, b in zip(temps, temps[1:], strict=False))
