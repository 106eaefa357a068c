"""docs/tutorial.md is a promise: its commands run as written and do what the page says.

The page is read, not copied: every ``toml`` block headed ``# save as: NAME``
is written to ``NAME`` and every ``corr-cad ...`` line of a ``bash`` block is
run, in page order, in one empty folder, through this checkout
(``python -m corr_cad``). Then the numbers and choices the page states are
read back from the files the steps wrote.

``python tests/test_tutorial.py`` runs the page the same way and writes its
pictures into ``docs/images/tutorial_*.png`` (downscaled, 64 colours), the
customer page's through headless Chromium where ``chromium`` is installed.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "tutorial.md"
FENCE = re.compile(r"^```(\w*)[^\n]*\n(.*?)^```", re.M | re.S)

#: The page's pictures: (file a step writes, picture in docs/images, width in pixels).
PICTURES = [
    ("step1/preview.png", "tutorial_1_preview.png", 640),
    ("step2/hysteresis.png", "tutorial_2_hysteresis.png", 760),
    ("step3/montecarlo.png", "tutorial_3_montecarlo.png", 760),
    ("step4/modification_tradeoff.png", "tutorial_4_tradeoff.png", 640),
    ("step5b/hysteresis.png", "tutorial_5_assembled.png", 760),
    ("step6/modification.png", "tutorial_6_modification.png", 640),
    ("step7/pareto.png", "tutorial_7_pareto.png", 640),
]
#: The page's screenshots of HTML pages: (page a step writes, picture, width, height kept).
SCREENSHOTS = [("step9/datasheet.html", "tutorial_9_datasheet_page.png", 760, 912)]


def steps(text: str) -> list[tuple[str, str, str]]:
    """``("file", name, content)`` and ``("run", command, "")`` in page order."""
    out = []
    for m in FENCE.finditer(text):
        kind, body = m.group(1), m.group(2)
        first = body.splitlines()[0] if body else ""
        if kind == "toml" and first.startswith("# save as: "):
            out.append(("file", first[len("# save as: ") :].strip(), body))
        elif kind == "bash":
            for line in body.splitlines():
                command = line.split("#", 1)[0].strip()
                if command.startswith("corr-cad "):
                    out.append(("run", command, ""))
    return out


def run_page(folder: Path) -> dict[str, subprocess.CompletedProcess]:
    """Run the tutorial in ``folder``; the result of each command, by its ``--out`` (or name)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    results = {}
    for kind, what, body in steps(PAGE.read_text()):
        if kind == "file":
            (folder / what).write_text(body)
            continue
        words = shlex.split(what)
        r = subprocess.run(
            [sys.executable, "-m", "corr_cad", *words[1:]],
            cwd=folder,
            capture_output=True,
            text=True,
            env=env,
        )
        key = words[words.index("--out") + 1] if "--out" in words else words[-1]
        results[key] = r
    return results


@pytest.fixture(scope="module")
def tutorial(tmp_path_factory):
    folder = tmp_path_factory.mktemp("tutorial")
    return folder, run_page(folder)


def test_the_page_has_ten_steps_of_commands_files_and_pictures():
    text = PAGE.read_text()
    runs = [w for k, w, _ in steps(text) if k == "run"]
    files = [w for k, w, _ in steps(text) if k == "file"]
    assert runs[0] == "corr-cad new my_drive.toml" and len(runs) == 13
    assert files == [
        "datasheet.toml",
        "tolerances.toml",
        "modify.toml",
        "assembly.toml",
        "assembled.toml",
        "shop.toml",
        "size.toml",
        "drive.toml",
        "life.toml",
        "first_stage.toml",
    ]
    assert "Ten steps" in text and len(re.findall(r"^## \d+\. ", text, re.M)) == 10
    for picture in [p for _, p, _ in PICTURES] + [p for _, p, _, _ in SCREENSHOTS]:
        assert f"(images/{picture})" in text, picture
        assert (ROOT / "docs" / "images" / picture).stat().st_size < 150_000  # kept small


@pytest.mark.slow
def test_every_command_runs_and_exits_0(tutorial):
    folder, results = tutorial
    assert len(results) == 13
    for key, r in results.items():
        assert r.returncode == 0, (key, r.stderr[-2000:])
    for made, _, _ in PICTURES:
        assert (folder / made).stat().st_size > 10_000, made


@pytest.mark.slow
def test_the_numbers_the_page_states(tutorial):
    folder, results = tutorial
    text = PAGE.read_text()
    # Step 1: the commented scene and its four profiles.
    assert "[design]" in (folder / "my_drive.toml").read_text()
    names = json.loads((folder / "step1" / "manifest.json").read_text())["files"]
    assert {"inner_gear.dxf", "disk_cam.dxf", "roller.dxf", "teeth_frame.dxf"} <= set(names)
    # Step 2: the figures quoted, and the customer's page.
    ds = json.loads((folder / "step2" / "datasheet.json").read_text())
    assert f"{ds['backlash_arcmin']['max']:.3f}" == "0.425" and "backlash 0.425 arcmin" in text
    assert f"{ds['lost_motion_arcmin']['max']:.3f}" == "0.591"
    rig = ds["torsional_rigidity_Nm_per_arcmin"]
    assert f"{rig['catalogue']:,.0f}" == "1,136"
    assert f"{rig['contact_only']['min']:,.0f}" == "21,256"
    assert (folder / "step2" / "datasheet.html").stat().st_size > 10_000
    # Step 3: the gate passes, with the probabilities quoted.
    mc = json.loads((folder / "step3" / "montecarlo_summary.json").read_text())
    assert mc["failure_probability"]["max_contact_pressure"] == 0.0
    assert mc["failure_probability"]["min_loaded_rollers"] == 0.005
    # Step 4: the chosen modification, as the page and the later scenes use it.
    mod = json.loads((folder / "step4" / "modification.json").read_text())
    chosen = mod["chosen"]
    assert (chosen["equidistant_mm"], chosen["shift_mm"]) == (0.0, 0.02)
    assert f"{chosen['backlash_arcmin']['p95']['value']:.3f}" == "1.818"
    assert chosen["binding_probability"]["value"] == 0.0 and len(mod["candidates"]) == 16
    for later in ("assembly.toml", "assembled.toml", "shop.toml"):
        scene = tomllib.loads((folder / later).read_text())
        assert scene["modification"]["shift_mm"] == chosen["shift_mm"], later
    assert (folder / "step4" / "modified.toml").is_file()
    # Step 5: the class, and the scene that assembles it.
    fit = json.loads((folder / "step5" / "assembly.json").read_text())
    assert fit["chosen_class_um"] == 8.0
    assembled = tomllib.loads((folder / "assembled.toml").read_text())
    assert assembled["errors"]["roller_radius_error"] * 1000.0 == fit["chosen_class_um"]
    b = json.loads((folder / "step5b" / "datasheet.json").read_text())["backlash_arcmin"]["max"]
    assert 0.1 < b < 0.5 and f"{b:.1f}" == "0.2"
    # Step 6: the shop files, of the modified profile.
    for name in ("inner_gear.dxf", "inner_gear_edm.nc", "inner_gear_edm.dxf"):
        assert (folder / "step6" / name).stat().st_size > 1000, name
    assert (folder / "step6" / "inner_gear_nominal.csv").is_file()
    m = json.loads((folder / "step6" / "manifest.json").read_text())
    assert m["modification"]["shift_mm"] == 0.02
    # Step 7: the front, its lightest design, and that design's own run.
    import csv

    with open(folder / "step7" / "pareto.csv", newline="") as f:
        front = list(csv.DictReader(f))
    first, last = front[0], front[-1]
    assert len(front) == 7 and first["design"] == "design_01.toml"
    assert len([row for row in front if row["design"]]) == 5
    chosen = (first["cam_radius"], first["eccentricity"], first["needles"])
    assert chosen == ("130.0", "3.3", "42.0")
    assert f"{float(first['mass_kg']):.2f}" == "21.11"
    assert f"{float(last['mass_kg']):.2f}" == "22.25"
    assert f"{float(first['life_margin']):.2f}" == "1.05"
    assert f"{float(last['life_margin']):.2f}" == "1.93"
    ref = json.loads((folder / "step7" / "manifest.json").read_text())["sizing"]["reference"]
    assert f"{ref['mass_kg']:.2f}" == "22.24" and f"{ref['life_margin']:.2f}" == "1.10"
    life = json.loads((folder / "step7a" / "datasheet.json").read_text())["life_h"]["system"]
    assert life == float(first["life_h"]) and f"{life:,.0f}" == "6,297"
    # Step 4's p95 contact pressure, as the page quotes it.
    p = mod["chosen"]["peak_pressure_MPa"]
    assert f"{p['p95']['value']:,.0f}" == "2,708" and f"{p['p50']['value']:,.0f}" == "2,291"
    # Step 8: the drive on needles with a clearance: the play is the needles'.
    d8 = json.loads((folder / "step8" / "datasheet.json").read_text())
    assert (d8["model"], d8["contact_law"], d8["bearing"]["diametral_clearance_mm"]) == (
        "drive",
        "palmgren",
        0.005,
    )
    assert f"{d8['backlash_arcmin']['max']:.4f}" == "0.1889"
    assert f"{d8['lost_motion_arcmin']['max']:.4f}" == "0.2855"
    rig8 = d8["torsional_rigidity_Nm_per_arcmin"]
    assert f"{rig8['contact_only']['min']:,.0f}" == "3,477"
    for side in ("positive", "negative"):
        share = d8["row_a_share_by_direction"][side]
        assert f"{share['min']:.3f}" == f"{share['max']:.3f}" == "0.500", side
    # Step 9: efficiency, torques and lives, and the page that shows them.
    d9 = json.loads((folder / "step9" / "datasheet.json").read_text())
    assert f"{d9['efficiency_forward']['min']:.4f}" == "0.8748"
    assert f"{d9['efficiency_backdriving']['min']:.4f}" == "0.8687"
    assert not d9["efficiency_backdriving"]["self_locking"]
    assert d9["starting_torque_Nm"]["max"] == 0.0 and d9["backdriving_torque_Nm"]["max"] == 0.0
    lives = d9["life_h"]
    assert f"{lives['bearing_row1']:,.0f}" == f"{lives['bearing_row2']:,.0f}" == "5,346"
    assert min(lives[k] for k in ("cam_row1", "cam_row2", "ring_row1", "ring_row2")) > 1e6
    assert f"{lives['system']:,.0f}" == "2,882"
    assert f"{d9['rated_torque_from_life_Nm']['value']:,.0f}" == "2,295"
    page = (folder / "step9" / "datasheet.html").read_text()
    assert "Short life" in page and "Rated torque from life" in page
    # Step 10: the whole drive's play, the first stage's included.
    d10 = json.loads((folder / "step10" / "datasheet.json").read_text())
    whole = d10["whole_drive"]
    assert d10["backlash_arcmin"]["max"] == 0.0
    assert f"{d10['lost_motion_arcmin']['max']:.6f}" == "0.007258"
    assert f"{whole['backlash_arcmin']['value']:.4f}" == "0.2351"
    assert f"{whole['backlash_arcmin']['first_stage']:.4f}" == "0.2351"
    assert f"{whole['lost_motion_arcmin']['value']:.4f}" == "0.2428"
    ratio = whole["lost_motion_arcmin"]["value"] / whole["lost_motion_arcmin"]["second_stage"]
    assert round(ratio) == 33 and "0.2428 arcmin, 33 times" in " ".join(text.split())
    page10 = (folder / "step10" / "datasheet.html").read_text()
    rows = re.findall(r"<tr><td>([^<]*)</td>", page10)
    assert rows[1:5] == [
        "Backlash, whole drive",
        "Lost motion, whole drive",
        "Backlash, second stage",
        "Lost motion, second stage",
    ]
    assert "backlash 61 um" in results["step10"].stdout and "(61 um on each mesh)" in text
    template = tomllib.loads((ROOT / "templates" / "compound.toml").read_text())
    scene = tomllib.loads((folder / "first_stage.toml").read_text())
    assert all(template["first_stage"][k] == v for k, v in scene["first_stage"].items())
    assert "datasheet" in template["export"]["formats"]


@pytest.mark.slow
def test_every_warning_a_step_prints_is_on_the_page(tutorial):
    """Each step's warning lines stand in the page word for word (and are explained there)."""
    _, results = tutorial
    text = " ".join(PAGE.read_text().split())
    warned = {}
    for key, r in results.items():
        for line in (r.stdout + r.stderr).splitlines():
            if "warning" in line.lower():
                warned[key] = line.strip()
                assert " ".join(line.split()) in text, (key, line)
    assert sorted(warned) == ["step4", "step9"]


@pytest.mark.slow
def test_wider_tolerances_fail_the_gate_with_exit_1(tmp_path):
    """Step 3's remark: with +-5 um on the cam and the eccentricity the gate fails."""
    text = dict((w, b) for k, w, b in steps(PAGE.read_text()) if k == "file")["tolerances.toml"]
    wide = text.replace("cam_radius = { uniform = 0.001 }", "cam_radius = { uniform = 0.005 }")
    wide = wide.replace("eccentricity = { uniform = 0.001 }", "eccentricity = { uniform = 0.005 }")
    assert wide.count("0.005") == 2
    (tmp_path / "wide.toml").write_text(wide)
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "wide.toml", "--out", "o", "--quiet"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"},
    )
    assert r.returncode == 1 and "failure probability" in r.stderr


def _pictures(folder: Path) -> None:
    """Write the page's pictures from a run of it (downscaled, 64 colours)."""
    from PIL import Image

    for made, picture, width in PICTURES:
        im = Image.open(folder / made).convert("RGB")
        im = im.resize((width, round(im.height * width / im.width)), Image.LANCZOS)
        im.quantize(colors=64).save(ROOT / "docs" / "images" / picture, optimize=True)
    import shutil
    import tempfile

    chromium = shutil.which("chromium")
    for page, picture, width, height in SCREENSHOTS if chromium else []:
        with tempfile.TemporaryDirectory() as tmp:
            shot = Path(tmp) / "shot.png"
            subprocess.run(
                [chromium, "--headless", "--no-sandbox", "--hide-scrollbars",
                 f"--screenshot={shot}", "--window-size=1200,2000", str(folder / page)],
                capture_output=True, check=True, timeout=120,
            )  # fmt: skip
            im = Image.open(shot).convert("RGB")
        im = im.resize((width, round(im.height * width / im.width)), Image.LANCZOS)
        im = im.crop((0, 0, width, min(height, im.height)))  # the figures and the first curve
        im = im.quantize(colors=64, method=Image.Quantize.FASTOCTREE)  # keeps the red curves
        im.save(ROOT / "docs" / "images" / picture, optimize=True)


if __name__ == "__main__":
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        for key, r in run_page(Path(tmp)).items():
            print(key, r.returncode, r.stderr.strip().splitlines()[-1:] if r.returncode else "")
        _pictures(Path(tmp))
