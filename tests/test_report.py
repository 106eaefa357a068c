"""report.html: self-contained, parses as HTML, embeds every plot it names, true numbers."""

from __future__ import annotations

import base64
import csv
import json
import shutil
import subprocess
import sys
from html.parser import HTMLParser

import pytest

SCENE = """
[design]
tooth_count = 25
cam_radius = 135.0
roller_radius = 8.0
eccentricity = 3.5

[export]
formats = ["dxf", "png", "forces", "montecarlo", "allocation", "sweeps", "report"]

[load]
input_torque = 1.1e5

[solver]
positions = 360

[checks]
max_contact_pressure = 2500.0
max_gear_force = 8000.0

[tolerances]
roller_radius = { normal = 0.001 }
cam_radius = { uniform = 0.002 }

[montecarlo]
samples = 30
positions = 36
allocation_samples = 10

[sweeps]
points = 2
positions = 52
"""

VOID = {"meta", "img", "br", "hr", "link", "input", "col", "area", "base", "wbr", "source"}


class _Page(HTMLParser):
    """Collects images, captions, links and checks that elements nest properly."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.stack: list[str] = []
        self.images: list[dict] = []
        self.captions: list[str] = []
        self.urls: list[str] = []
        self.cells: list[str] = []
        self._caption = None
        self._cell = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "img":
            self.images.append(a)
        for key in ("src", "href"):
            if key in a and not a[key].startswith(("data:", "#")):
                self.urls.append(a[key])
        if tag in ("script", "link", "iframe", "object"):
            self.urls.append(f"<{tag}>")
        if tag not in VOID:
            self.stack.append(tag)
        if tag == "figcaption":
            self._caption = ""
        if tag == "td":
            self._cell = ""

    def handle_endtag(self, tag):
        assert self.stack and self.stack[-1] == tag, (tag, self.stack[-3:])
        self.stack.pop()
        if tag == "figcaption":
            self.captions.append(self._caption)
            self._caption = None
        if tag == "td":
            self.cells.append(self._cell.strip())
            self._cell = None

    def handle_data(self, data):
        if self._caption is not None:
            self._caption += data
        if self._cell is not None:
            self._cell += data


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """The CLI in a separate process, on a folder that holds other files too."""
    root = tmp_path_factory.mktemp("report")
    (root / "notes.txt").write_text("not ours\n")
    scene = root / "design.toml"
    scene.write_text(SCENE)
    out = root / "out"
    subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(out), "--quiet"],
        check=True,
        cwd=root,
    )
    page = _Page()
    html = (out / "report.html").read_text(encoding="utf-8")
    page.feed(html)
    page.close()
    return out, html, page


@pytest.mark.slow
def test_report_parses_and_embeds_every_plot_it_names(run):
    out, html, page = run
    assert page.stack == []  # every element closed
    assert html.startswith("<!DOCTYPE html>")
    pngs = sorted(p.name for p in out.glob("*.png"))
    assert "forces.png" in pngs and "montecarlo.png" in pngs and len(pngs) >= 9
    assert sorted(i["alt"] for i in page.images) == pngs
    for img in page.images:
        prefix = "data:image/png;base64,"
        assert img["src"].startswith(prefix)
        data = base64.b64decode(img["src"][len(prefix) :], validate=True)
        assert data == (out / img["alt"]).read_bytes()
    named = sorted(c.split(":")[0] for c in page.captions)
    assert named == pngs
    manifest = json.loads((out / "manifest.json").read_text())
    assert "report.html" in manifest["files"]


@pytest.mark.slow
def test_report_needs_no_network(run):
    _, html, page = run
    assert page.urls == []
    assert "http://" not in html and "https://" not in html


def _cell_after(cells: list[str], label: str, k: int = 1) -> str:
    return cells[cells.index(label) + k]


@pytest.mark.slow
def test_report_numbers_are_the_run_s_numbers(run):
    out, _, page = run
    cells = page.cells
    # Peak gear force over all rollers and positions, read independently from forces.csv.
    with open(out / "forces.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    best = max(rows, key=lambda r: float(r["F_n"]))
    assert _cell_after(cells, "gear force F_n") == f"{float(best['F_n']):,.4g}"
    assert _cell_after(cells, "gear force F_n", 3) == best["roller"]
    assert float(_cell_after(cells, "gear force F_n", 4)) == pytest.approx(
        float(best["crank_angle_deg"]), abs=1e-9
    )
    m = json.loads((out / "manifest.json").read_text())
    # Undercut margin: the admissible radius (10.053 mm for Table 1) minus r = 8.
    assert _cell_after(cells, "largest roller radius without undercut") == "10.05"
    assert _cell_after(cells, "margin to it (admissible - r)") == "2.053"
    tip = m["undercut"]["min_working_radius_mm"]
    label = "tip radius of the working profile (smallest radius of curvature)"
    assert _cell_after(cells, label) == f"{tip:.4g}"
    for name, r in m["checks"].items():
        assert _cell_after(cells, name, 3) == f"{r['margin']:,.4g}"
        assert _cell_after(cells, name, 5) == ("pass" if r["passed"] else "FAIL")
    # Allocation in the user's own terms.
    assert _cell_after(cells, "roller_radius", 1) in ("sigma",)
    assert "uniform half-width" in cells
    # The DXF's measured accuracy is stated beside the file.
    acc = m["accuracy"]["working_profile"]["max_deviation_mm"]
    row = _cell_after(cells, "inner_gear.dxf")
    assert f"measured max deviation {acc:.3g} mm" in row


@pytest.mark.slow
def test_every_force_cell_is_its_own_column_s_peak(run):
    """Each row of the peaks table, and roller 1's table, recomputed from forces.csv.

    The old test checked the F_n row only, so a cell filled from the
    neighbouring field (peak F_j shown as peak F_n) passed. Value, roller and
    crank angle of every row are checked.
    """
    out, _, page = run
    cells = page.cells
    with open(out / "forces.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    for label, col in (
        ("cam force F_j", "F_j"),
        ("gear force F_n", "F_n"),
        ("slot force |F_s|", "F_s"),
        ("contact pressure, cam", "p_cam"),
        ("contact pressure, gear", "p_gear"),
        ("contact pressure, slot", "p_slot"),
    ):
        best = max(rows, key=lambda r: abs(float(r[col])))
        assert _cell_after(cells, label) == f"{abs(float(best[col])):,.4g}", label
        assert _cell_after(cells, label, 3) == best["roller"], label
        angle = float(_cell_after(cells, label, 4).replace(",", ""))
        assert angle == pytest.approx(float(best["crank_angle_deg"]), abs=1e-9), label
    one = [r for r in rows if r["roller"] == "1"]
    loaded = [r for r in one if float(r["F_j"]) > 0]

    def mean(col):
        return sum(float(r[col]) for r in loaded) / len(loaded)

    fs = [float(r["F_s"]) for r in one]
    for label, value in (
        ("mean F_j (loaded part)", mean("F_j")),
        ("mean F_n (loaded part)", mean("F_n")),
        ("peak F_n", max(float(r["F_n"]) for r in one)),
        ("F_s peak to peak", max(fs) - min(fs)),
    ):
        assert _cell_after(cells, label) == f"{value:,.4g}", label


@pytest.mark.slow
@pytest.mark.skipif(not shutil.which("chromium"), reason="no headless Chromium here")
def test_report_opens_in_headless_chromium(run, tmp_path):
    out, _, page = run
    shot = tmp_path / "report.png"
    cmd = ["chromium", "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run"]
    dom = subprocess.run(
        [*cmd, "--dump-dom", (out / "report.html").as_uri()],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert dom.returncode == 0, dom.stderr[-2000:]
    assert "corr-cad report: design" in dom.stdout
    assert dom.stdout.count("<img") == len(page.images)
    subprocess.run(
        [*cmd, f"--screenshot={shot}", "--window-size=1200,2400", (out / "report.html").as_uri()],
        capture_output=True,
        timeout=600,
    )
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_report_with_step_files_states_their_read_back(tmp_path):
    """STEP parts and the assembly STEP both get an accuracy line (an assembly once crashed it)."""
    scene = tmp_path / "s.toml"
    scene.write_text(
        "[design]\ntooth_count = 5\ncam_radius = 30.0\nroller_radius = 3.0\neccentricity = 1.0\n"
        '[export]\nformats = ["step", "report"]\ntolerance = 0.01\n'
    )
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    html = (tmp_path / "o" / "report.html").read_text(encoding="utf-8")
    assert "read back: volume error" in html and "named instances" in html


def test_every_monte_carlo_metric_has_a_label_and_unit():
    """The report names every column the Monte Carlo summarises: the force
    metrics and the datasheet pass's (a missing one once crashed the report)."""
    from corr_cad.export.report import METRIC_LABELS
    from corr_cad.mechanics.row.mc_kernel import METRICS
    from corr_cad.tolerance.mc_datasheet import DATASHEET_MC_METRICS
    from corr_cad.tolerance.montecarlo import FLAG_METRICS

    force = [m.replace("_rad", "_arcmin") for m in METRICS]  # backlash is given in arcmin
    for m in [*force, *DATASHEET_MC_METRICS]:
        if m not in FLAG_METRICS:
            assert m in METRIC_LABELS, m
    assert METRIC_LABELS["lost_motion_arcmin"][1] == "arcmin"
    assert METRIC_LABELS["torsional_rigidity_Nm_per_arcmin"][1] == "N*m/arcmin"
    assert METRIC_LABELS["transmission_error_arcsec"][1] == "arcsec"


def test_every_nominal_check_has_the_unit_its_scene_key_states():
    """The report's Checks table gives each limit the unit of its ``[checks]`` key
    (the first stage's two stresses once had none)."""
    import dataclasses
    import re

    from corr_cad.export.report import _CHECK_UNITS
    from corr_cad.run.scene.scene_schema import SCHEMA
    from corr_cad.tolerance.checks import Checks

    gates = {"max_failure_probability", "max_binding_probability"}  # the Monte Carlo's own rows
    for f in dataclasses.fields(Checks):
        if f.name in gates:
            continue
        stated = re.search(
            r", (N\*m/arcmin|MPa|N|arcmin|arcsec|h)(?=$| \()", SCHEMA["checks"][f.name].help
        )
        assert _CHECK_UNITS[f.name] == (stated.group(1) if stated else ""), f.name
    assert _CHECK_UNITS["max_first_stage_bending_MPa"] == "MPa"
