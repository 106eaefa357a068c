"""Hostile values on the crankshaft beside the needle bearings and the elastic bodies:
each refused up front in one line (key, value, allowed range, a value that works), and
the crank gear placed between the eccentrics twisting each through its own segment."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from corr_cad.errors import SceneError
from corr_cad.mechanics.crank.crankshaft import STEEL_E as E
from corr_cad.mechanics.crank.crankshaft import STEEL_NU as NU
from corr_cad.mechanics.crank.crankshaft import Crankshaft
from corr_cad.mechanics.drive.drive_crank import CrankSupport
from corr_cad.run.scene.scene import parse_scene

ROOT = Path(__file__).resolve().parents[1]
NEEDLES = {"needles": 40, "needle_diameter": 6.0, "needle_length": 12.0}


def _drive(crankshaft: dict, needles: bool = True, crank=None, eccentric=None) -> dict:
    data = {
        "solver": {"model": "drive", "contact_law": "palmgren"},
        "load": {"input_torque": 1.1e5},
        "crankshaft": crankshaft,
        "bearings": {},
    }
    if needles:
        data["bearings"]["eccentric"] = {**NEEDLES, **(eccentric or {})}
    if crank is not None:
        data["bearings"]["crank"] = crank
    return data


@pytest.mark.parametrize(
    "crank,eccentric,pattern",
    [
        # 1000 rollers of 12 mm on an 87 mm pitch circle solved without a word.
        (
            {"rollers": 1000},
            None,
            r"^\[bearings\.crank\] rollers = 1000: 1000 rollers of 12 mm do not fit on the "
            r"pitch circle of 87 mm; allowed range is \[3, 22\], e\.g\. 18$",
        ),
        (
            {"pitch_diameter": 40.0},
            None,
            r"^\[bearings\.crank\] pitch_diameter = 40: the 18 rollers of 12 mm \(derived\) "
            r"do not fit on it; allowed range is \(69\.11, 5000\] mm, e\.g\. 87$",
        ),
        (
            {"pitch_diameter": 13.0, "rollers": 3},
            None,
            r"^\[bearings\.crank\] pitch_diameter = 13: the 3 rollers of 12 mm do not fit on "
            r"it; allowed range is \(13\.86, 5000\] mm, e\.g\. 87$",
        ),
        (
            {"pitch_diameter": 80.0, "rollers": 21},
            None,
            r"^\[bearings\.crank\] rollers = 21: 21 rollers of 12 mm do not fit on the pitch "
            r"circle of 80 mm; allowed range is \[3, 20\], e\.g\. 18$",
        ),
        (
            {"pitch_diameter": 62.0, "rollers": 6, "roller_diameter": 4.0},
            None,
            r"^\[bearings\.crank\] pitch_diameter = 62: the inner raceway \(58 mm\) must sit "
            r"on the shaft \(60 mm\): allowed range is \[64, 5000\] mm, e\.g\. 87$",
        ),
    ],
)
def test_support_bearings_that_cannot_be_built_are_refused(crank, eccentric, pattern):
    with pytest.raises(SceneError, match=pattern) as err:
        parse_scene(_drive({"shaft_diameter": 60.0}, crank=crank, eccentric=eccentric))
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    "crankshaft,needles,pattern",
    [
        # A 1 mm journal on a 60 mm shaft: the beam was built and the coupling ran 80
        # solves (about 100 s) before 'did not settle ... check shaft_diameter'.
        (
            {"eccentric_diameter": 1.0},
            True,
            r"^\[crankshaft\] eccentric_diameter = 1: the journal must hold the shaft "
            r"\(shaft_diameter 60 \+ 2 e = 67 mm at least\), e\.g\. 82\.4$",
        ),
        (
            {"shaft_diameter": 80.0},
            True,
            r"^\[crankshaft\] shaft_diameter = 80: .* allowed range is \(0, 75\.4\] mm, e\.g\. 60$",
        ),
        (
            {"shaft_diameter": 100.0},
            False,
            r"^\[crankshaft\] shaft_diameter = 100: .* allowed range is \(0, 87\.4\] mm, "
            r"e\.g\. 69$",
        ),
        (
            {"eccentric_diameter": 90.0},
            True,
            r"^\[crankshaft\] eccentric_diameter = 90: the needles \(6 mm\) must fit .*"
            r"allowed range is \(0, 82\.4\] mm, e\.g\. 82\.4$",
        ),
        (
            {"eccentric_diameter": 85.0},
            True,
            r"^\[crankshaft\] eccentric_diameter = 85: the needles \(6 mm\) must fit ",
        ),
        (
            {"eccentric_positions": [-100.0, 26.0]},
            True,
            r"^\[crankshaft\] eccentric_positions = \[-100\.0, 26\.0\]: eccentric A must lie "
            r"under row A's cam, z in \[0, 12\] mm, e\.g\. \[6\.0, 26\.0\]$",
        ),
        (
            {"eccentric_positions": [6.0, 6.0]},
            True,
            r"^\[crankshaft\] eccentric_positions = \[6\.0, 6\.0\]: eccentric B must lie "
            r"under row B's cam, z in \[20, 32\] mm",
        ),
    ],
)
def test_a_shaft_the_files_cannot_draw_is_refused_in_one_line(crankshaft, needles, pattern):
    with pytest.raises(SceneError, match=pattern) as err:
        parse_scene(_drive(crankshaft, needles))
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    "crankshaft",
    [
        {},
        {"shaft_diameter": 75.4, "eccentric_positions": [0.0, 32.0]},
        {"support_positions": [-80.0, -30.0]},  # both supports on one side: overhung
        {"eccentric_diameter": 82.4, "shaft_diameter": 5.0},
    ],
)
def test_the_limits_themselves_load(crankshaft):
    assert parse_scene(_drive(crankshaft)).crank is not None


def test_gear_between_the_eccentrics_twists_each_through_its_own_segment():
    """Gear at z = 55 between A (45) and B (65) on a uniform shaft: A twists by
    M_A 10 / (G J), B by M_B 10 / (G J), neither by the other's moment (the cross term
    was the twist of the nearer one's segment: M_B 10 / (G J) added to A)."""
    shaft = Crankshaft(60.0, 60.0, 12.0, (45.0, 65.0), (10.0, 110.0), 55.0)
    M = np.array([[4.0e4, 6.0e4]])
    th = CrankSupport(shaft).response(np.zeros((1, 2, 2)), M)["theta"][0]
    GJ = E / (2 * (1 + NU)) * math.pi * 60.0**4 / 32
    np.testing.assert_allclose(abs(th[0]), 4.0e4 * 10 / GJ, rtol=1e-12)
    np.testing.assert_allclose(abs(th[1]), 6.0e4 * 10 / GJ, rtol=1e-12)
    t = shaft.torsion_matrix()
    assert t[0, 1] == 0.0 and t[1, 0] == 0.0


def test_cli_refuses_a_journal_too_small_at_once(tmp_path):
    """Through the CLI from a folder with the user's files: exit 2, one line, nothing
    written, the other file untouched."""
    (tmp_path / "notes.txt").write_text("mine")
    scene = tmp_path / "s.toml"
    scene.write_text(
        "[export]\nformats = ['forces']\n[load]\ninput_torque = 1.1e5\n"
        "[solver]\nmodel = 'drive'\ncontact_law = 'palmgren'\nbodies = 'elastic'\n"
        "[bearings.eccentric]\nneedles = 40\nneedle_diameter = 6.0\nneedle_length = 12.0\n"
        "diametral_clearance = 0.005\n[crankshaft]\neccentric_diameter = 1.0\n"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert r.returncode == 2
    lines = [ln for ln in r.stderr.splitlines() if "warning" not in ln]
    assert lines == [
        "corr-cad: error: [crankshaft] eccentric_diameter = 1: the journal must hold the "
        "shaft (shaft_diameter 60 + 2 e = 67 mm at least), e.g. 82.4"
    ]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt", "s.toml"]
    assert (tmp_path / "notes.txt").read_text() == "mine"


def _soft_drive(dia: float, positions: int = 2):
    from corr_cad import GearDesign
    from corr_cad.mechanics.crank.bearing import EccentricBearing
    from corr_cad.mechanics.crank.support_bearing import SupportBearing
    from corr_cad.mechanics.drive.drive import solve_drive

    shaft = Crankshaft(dia, 82.4, 12.0, (6.0, 26.0), (-27.0, 59.0), -49.0)
    crank = CrankSupport(shaft, SupportBearing("cylindrical", 18, 12.0, 12.0, 87.0))
    angles = np.radians(np.linspace(0.0, 90.0, positions))
    return solve_drive(
        GearDesign(),
        1.1e5,
        angles,
        bearing=EccentricBearing(40, 6.0, 12.0, 0.005),
        contact_model="palmgren",
        crank=crank,
    )


def test_a_shaft_that_moves_the_eccentrics_beyond_e_is_refused_at_once():
    """A 2 mm shaft moves the eccentric centres by ~36 mm under the rigid crank's loads
    (the teeth are 2 e = 7 mm deep): refused on the first iterate, naming the key and a
    diameter that works (the 1 mm shaft ran 80 solves, ~100 s, before 'did not settle')."""
    from corr_cad.errors import SolverError

    with pytest.raises(SolverError) as err:
        _soft_drive(2.0)
    msg = str(err.value)
    assert "\n" not in msg
    assert "[crankshaft] shaft_diameter = 2 (with its support bearings) moves the eccentric " in msg
    assert "more than the eccentricity e = 3.5 mm" in msg and msg.endswith("shaft_diameter = 12")
    assert _soft_drive(12.0).success  # the value it suggests solves


@pytest.mark.slow
def test_cli_soft_shaft_with_elastic_bodies_and_clearance_refuses_in_one_line(tmp_path):
    """The 1 mm shaft on a given support bearing, elastic bodies, needles with clearance:
    exit 2 in one line (no hang, no traceback), nothing written."""
    scene = tmp_path / "s.toml"
    scene.write_text(
        "[export]\nformats = ['forces']\n[load]\ninput_torque = 1.1e5\n"
        "[solver]\nmodel = 'drive'\ncontact_law = 'palmgren'\nbodies = 'elastic'\n"
        "positions = 36\n"
        "[bearings.eccentric]\nneedles = 40\nneedle_diameter = 6.0\nneedle_length = 12.0\n"
        "diametral_clearance = 0.005\n[crankshaft]\nshaft_diameter = 1.0\n"
        "[bearings.crank]\nrollers = 18\nroller_diameter = 12.0\npitch_diameter = 87.0\n"
        "clearance = 0.05\n"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--workers", "1"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
    )
    assert r.returncode == 2
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("corr-cad: error")]
    assert len(lines) == 1 and "Traceback" not in r.stderr
    assert "[crankshaft] shaft_diameter = 1 (with its support bearings)" in lines[0]
    assert not (tmp_path / "outputs").exists() or not any((tmp_path / "outputs").iterdir())


SMALL_CHAIN = """[design]
tooth_count = 9
cam_radius = 45.0
roller_radius = 4.0
eccentricity = 1.5
[export]
formats = ["montecarlo"]
[load]
input_torque = 2.0e4
[solver]
model = "drive"
contact_law = "palmgren"
bodies = "elastic"
[tolerances]
roller_radius = { normal = 0.002 }
cam_radius = { normal = 0.002 }
[montecarlo]
samples = 6
positions = 9
[crankshaft]
shaft_diameter = 20.0
[bearings.crank]
"""


@pytest.mark.slow
def test_cli_monte_carlo_on_crank_and_bodies_says_so_and_keeps_its_bytes(tmp_path):
    """A Monte Carlo alone on the crank and the elastic bodies, from a folder with the
    user's own file: the console names the chain, and one worker, two workers and another
    PYTHONHASHSEED write the same bytes (manifest.json aside: it holds timings)."""
    (tmp_path / "notes.txt").write_text("mine")
    (tmp_path / "s.toml").write_text(SMALL_CHAIN)
    outs = []
    for i, (workers, seed) in enumerate((("1", "0"), ("2", "0"), ("2", "123"))):
        env = {
            **os.environ,
            "PYTHONPATH": str(ROOT),
            "PYTHONHASHSEED": seed,
            "CORR_CAD_CACHE_DIR": str(tmp_path / "cache"),
        }
        r = subprocess.run(
            [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", f"o{i}"]
            + ["--workers", workers],
            cwd=tmp_path,
            capture_output=True,
            text=True,
            env=env,
            timeout=600,
        )
        assert r.returncode == 0, r.stderr
        assert (
            "  every sample solved on the crankshaft on its support bearings and the elastic "
            "ring, frame and cams (FE) (model.samples_chain)" in r.stdout.splitlines()
        )
        outs.append(tmp_path / f"o{i}")
    names = sorted(p.name for p in outs[0].iterdir() if p.name != "manifest.json")
    assert "montecarlo.csv" in names
    for o in outs[1:]:
        assert sorted(p.name for p in o.iterdir() if p.name != "manifest.json") == names
        for n in names:
            assert (o / n).read_bytes() == (outs[0] / n).read_bytes(), n
    assert (tmp_path / "notes.txt").read_text() == "mine"
