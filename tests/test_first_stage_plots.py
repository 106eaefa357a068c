"""``first_stage.png``: the gears placed as in the assembly, the teeth in mesh with their backlash.

The references are written here: the wheel centres from the centre distance
and the 120 deg spacing, the gap of a centred tooth from the backlash and the
working pressure angle, the centroid by the shoelace formula.
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from shapely.geometry import Polygon

from corr_cad.export.first_stage_plots import placed_gear_outlines
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.first_stage import FirstStage, first_stage_geometry
from corr_cad.geometry.gear_outline import approximate_gear

TOL = 0.001
GEOM = first_stage_geometry(
    FirstStage(
        18, 36, 90, 1.5, 15.0, shift_pinion=0.5, shift_crank_gear=0.5, backlash_allowance=0.03
    )
)
OUTLINES = {
    k: approximate_gear(getattr(GEOM, k), TOL).vertices for k in ("pinion", "wheel", "crank_gear")
}


def _centroid(p: np.ndarray) -> np.ndarray:
    x, y = p[:, 0], p[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area = cross.sum() / 2
    return np.array([((x + xn) * cross).sum(), ((y + yn) * cross).sum()]) / (6 * area)


@pytest.mark.parametrize("crank_deg", [0.0, 37.0])
def test_gears_sit_on_their_axes_and_mesh_with_half_the_backlash_each_side(crank_deg):
    placed = placed_gear_outlines(GearDesign(), GEOM, OUTLINES, math.radians(crank_deg))
    assert set(placed) == {"pinion", "crank_gear", "wheel_1", "wheel_2", "wheel_3"}
    a = GEOM.centre_distance
    for k, beta in enumerate((0.0, 120.0, 240.0), 1):  # polar angles from +y, clockwise
        b = math.radians(beta)
        want = (a * math.sin(b), a * math.cos(b))
        assert _centroid(placed[f"wheel_{k}"]) == pytest.approx(want, abs=1e-6)
    assert _centroid(placed["pinion"]) == pytest.approx((0, 0), abs=1e-6)
    # A tooth centred in its space leaves half the circumferential backlash on
    # each flank: a normal gap of (j / 2) cos(alpha_w), within both outlines' tolerance.
    pinion, ring = Polygon(placed["pinion"]), Polygon(placed["crank_gear"])
    for k in (1, 2, 3):
        wheel = Polygon(placed[f"wheel_{k}"])
        for mesh, (gear, j) in enumerate(((pinion, GEOM.backlash[0]), (ring, GEOM.backlash[1]))):
            gap = wheel.distance(gear) if mesh == 0 else wheel.distance(ring.exterior)
            want = j / 2 * math.cos(math.radians(GEOM.working_pressure_angle_deg[mesh]))
            assert gap == pytest.approx(want, abs=2 * TOL), (k, mesh)
            if mesh == 0:
                assert wheel.intersection(gear).area == 0
            else:  # the wheel lies inside the crank gear's tooth outline
                assert ring.contains(wheel)


@pytest.mark.slow
def test_png_format_draws_the_first_stage_only_with_it(tmp_path):
    scene = tmp_path / "s.toml"
    base = '[export]\nformats = ["png"]\n'
    for name, text in (
        ("fs", "[first_stage]\npinion_teeth = 18\nwheel_teeth = 36\ncrank_gear_teeth = 90\n"
               "module = 1.5\nshift_pinion = 0.5\nshift_crank_gear = 0.5\nface_width = 15.0\n"),
        ("paper", ""),
    ):  # fmt: skip
        scene.write_text(text + base)
        r = subprocess.run(
            [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(tmp_path / name)],
            capture_output=True,
            text=True,
        )
        assert r.returncode == 0, r.stderr
    assert (tmp_path / "fs" / "first_stage.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not (tmp_path / "paper" / "first_stage.png").exists()
    assert (tmp_path / "fs" / "preview.png").read_bytes() == (
        tmp_path / "paper" / "preview.png"
    ).read_bytes()
