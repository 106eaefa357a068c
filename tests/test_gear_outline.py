"""Gear outlines against the textbook: the involute's closed form, the rack's trochoid.

The references are written here from their definitions and share no code
with corr_cad.geometry.involute; the outlines are read back from the DXF files.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys

import ezdxf
import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from corr_cad.geometry.first_stage import FirstStage, first_stage_geometry
from corr_cad.geometry.gear_outline import approximate_gear

TOL = 0.001
M, ALPHA, J = 1.5, math.radians(20.0), 0.03
STAGE = FirstStage(
    18, 36, 90, M, 15.0, shift_pinion=0.5, shift_crank_gear=0.5, backlash_allowance=J
)
GEOM = first_stage_geometry(STAGE)


@pytest.fixture(scope="module")
def dxf_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("gears")
    scene = out / "s.toml"
    scene.write_text(
        "[first_stage]\npinion_teeth = 18\nwheel_teeth = 36\ncrank_gear_teeth = 90\n"
        "module = 1.5\nshift_pinion = 0.5\nshift_crank_gear = 0.5\nface_width = 15.0\n"
        'backlash_allowance = 0.03\n[export]\nformats = ["dxf"]\n'
    )
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(out / "o")],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    return out / "o"


def _outline(path) -> np.ndarray:
    doc = ezdxf.readfile(path)
    (pl,) = doc.modelspace().query('LWPOLYLINE[layer=="PROFILE"]')
    return np.array([p[:2] for p in pl.get_points()])


def _polar(p):  # radius, polar angle from +y growing clockwise
    return np.hypot(p[:, 0], p[:, 1]), np.arctan2(p[:, 0], p[:, 1])


def _chord_distance(q, chain):
    a, b = chain[:-1], chain[1:]
    ab = b - a
    t = np.einsum("qij,ij->qi", q[:, None, :] - a[None], ab) / np.einsum("ij,ij->i", ab, ab)
    foot = a[None] + np.clip(t, 0, 1)[..., None] * ab[None]
    return np.linalg.norm(q[:, None, :] - foot, axis=-1).min(axis=1)


def _involute(rb, t):  # the textbook's closed form, unwinding anticlockwise from (rb, 0)
    return rb * np.stack([np.cos(t) + t * np.sin(t), np.sin(t) - t * np.cos(t)], axis=-1)


def _inv(a):
    return np.tan(a) - a


@pytest.mark.parametrize("part", ["pinion", "wheel", "crank_gear"])
def test_involute_flank_against_the_closed_form(dxf_dir, part):
    g = getattr(GEOM, part)
    z, x = g.teeth, g.shift
    r = M * z / 2
    rb = r * math.cos(ALPHA)
    if part == "crank_gear":  # the space is shaped like an external tooth
        space = M * (math.pi / 2 + 2 * x * math.tan(ALPHA)) + J
        eta_b = space / (2 * r) + _inv(ALPHA)  # the space's half-angle on the base circle
    else:
        s = M * (math.pi / 2 + 2 * x * math.tan(ALPHA)) - J
        eta_b = math.pi / z - (s / (2 * r) + _inv(ALPHA))
    ra, rf = g.tip, g.form_radius()
    lo, hi = sorted((ra, rf))
    p = _outline(dxf_dir / f"{part}.dxf")
    rad, psi = _polar(p)
    flank = p[(rad > lo + 1e-6) & (rad < hi - 1e-6) & (psi > 0) & (psi < math.pi / z)]
    assert len(flank) >= 5
    fr, fpsi = _polar(flank)
    theta = (eta_b - fpsi) if part == "crank_gear" else (fpsi - eta_b)
    local = np.stack([fr * np.cos(theta), fr * np.sin(theta)], axis=-1)
    t_v = np.sqrt((fr / rb) ** 2 - 1)
    # every vertex on the closed form (the involute point at its radius)
    assert np.abs(local - _involute(rb, t_v)).max() < 1e-9
    # every point of the closed form within the tolerance of the chords
    t = np.linspace(t_v.min(), t_v.max(), 3000)  # between the first and last flank vertex
    chain = local[np.argsort(t_v)]
    d = _chord_distance(_involute(rb, t), chain)
    assert d.max() <= TOL and d.max() > 0.1 * TOL  # a real polyline, near its tolerance


@pytest.mark.parametrize("part", ["pinion", "wheel"])
def test_fillet_is_the_envelope_of_the_rack_tip_round(dxf_dir, part):
    """Each fillet vertex lies rho from the trochoid of the rack's tip-round centre."""
    g = getattr(GEOM, part)
    z, x = g.teeth, g.shift
    r = M * z / 2
    rho = 0.38 * M  # ISO 53 profile A
    s = M * (math.pi / 2 + 2 * x * math.tan(ALPHA)) - J
    w = (math.pi * M - s) / 2  # the rack tooth's half-width on the pitch line
    d_c = (1.25 - x) * M - rho  # depth of the round's centre below the pitch line
    x_c = w - d_c * math.tan(ALPHA) - rho / math.cos(ALPHA)

    def centre(phi):  # rack rolled by r phi, seen from the gear turned back by phi
        cx, cy = x_c - r * phi, r - d_c
        return np.array(
            [cx * math.cos(phi) + cy * math.sin(phi), -cx * math.sin(phi) + cy * math.cos(phi)]
        )

    p = _outline(dxf_dir / f"{part}.dxf")
    rad, psi = _polar(p)
    fil = p[
        (rad > g.root_radius + 1e-4)
        & (rad < g.form_radius() - 1e-4)
        & (psi > 0)
        & (psi < math.pi / z)
    ]
    assert len(fil) >= 5
    phi0, phi1 = (x_c - d_c / math.tan(ALPHA)) / r, x_c / r
    for q in fil:
        res = minimize_scalar(
            lambda f, q=q: np.linalg.norm(centre(f) - q),
            bounds=(phi0 - 0.2, phi1 + 0.2),
            method="bounded",
            options={"xatol": 1e-12},
        )
        assert res.fun == pytest.approx(rho, abs=1e-7)


@pytest.mark.parametrize("part", ["pinion", "wheel", "crank_gear"])
def test_outline_measured_within_the_tolerance(dxf_dir, part):
    o = approximate_gear(getattr(GEOM, part), TOL)
    assert o.within_tolerance and set(o.deviation_by_kind) == {"root", "fillet", "involute", "tip"}
    doc = ezdxf.readfile(dxf_dir / f"{part}.dxf")
    assert float(doc.header.custom_vars.get("corr_cad.max_deviation_mm")) <= TOL
    assert len(_outline(dxf_dir / f"{part}.dxf")) == len(o.vertices)


def test_closed_outline_area_against_the_tooth_count(dxf_dir):
    """The outline is closed and simple: its area lies between root and tip circles."""
    for part in ("pinion", "wheel", "crank_gear"):
        g = getattr(GEOM, part)
        p = _outline(dxf_dir / f"{part}.dxf")
        area = 0.5 * abs(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))
        lo, hi = sorted((g.root_radius, g.tip))
        assert math.pi * lo**2 < area < math.pi * hi**2


def test_step_splines_follow_the_closed_form_involute():
    """The B-splines the STEP files are made of: the + flank of space 0 on the involute."""
    from corr_cad.geometry.gear_outline import spline_gear

    g = GEOM.pinion
    z, x = g.teeth, g.shift
    r = M * z / 2
    rb = r * math.cos(ALPHA)
    s = M * (math.pi / 2 + 2 * x * math.tan(ALPHA)) - J
    eta_b = math.pi / z - (s / (2 * r) + _inv(ALPHA))
    gs = spline_gear(g, TOL)
    assert gs.within_tolerance and gs.max_deviation <= 0.5 * TOL
    spl = gs.splines[6]  # tip -, involute -, fillet -, root -, root +, fillet +, involute +
    p = spl(np.linspace(0, 1, 2001))
    fr, fpsi = _polar(p)
    theta = fpsi - eta_b
    t = np.sqrt((fr / rb) ** 2 - 1)
    # the involute point at the same radius: the distance along the circle bounds the gap
    dev = np.abs(theta - (t - np.arctan(t))) * fr
    assert dev.max() <= 0.5 * TOL


def test_round_parts_are_drawn_at_their_stated_sizes(dxf_dir):
    from corr_cad.geometry.design import GearDesign
    from corr_cad.geometry.first_stage_parts import first_stage_layout

    lay = first_stage_layout(GearDesign(), GEOM)
    want = {
        "crankshaft": {"OUTER_1": lay.rim_outer, "OUTER_2": lay.shaft_radius},
        "wheel_bearing": {"OUTER_1": lay.wheel_bore, "BORE_1": lay.wheel_bearing_inner},
        "crank_bearing": {"OUTER_1": lay.crank_bearing_outer, "BORE_1": lay.shaft_radius},
    }
    for part, layers in want.items():
        doc = ezdxf.readfile(dxf_dir / f"{part}.dxf")
        got = {c.dxf.layer: c.dxf.radius for c in doc.modelspace().query("CIRCLE")}
        assert got == pytest.approx(layers), part
    assert lay.shaft_radius == GearDesign().cam_bore_radius  # the cams sit on the shaft


def test_gear_files_hold_every_contour_of_the_part(dxf_dir):
    """The bore of the pinion and the wheel, the crank gear's rim: the file alone cuts the part."""
    from corr_cad.geometry.design import GearDesign
    from corr_cad.geometry.first_stage_parts import first_stage_layout

    lay = first_stage_layout(GearDesign(), GEOM)
    want = {
        "pinion": {"BORE": lay.pinion_bore},
        "wheel": {"BORE": lay.wheel_bore},
        "crank_gear": {"RIM_OUTER": lay.rim_outer},
    }
    for part, cut in want.items():
        g = getattr(GEOM, part)
        doc = ezdxf.readfile(dxf_dir / f"{part}.dxf")
        got = {c.dxf.layer: c.dxf.radius for c in doc.modelspace().query("CIRCLE")}
        assert got == pytest.approx(
            {
                **cut,
                "PITCH_CIRCLE": M * g.teeth / 2,
                "BASE_CIRCLE": M * g.teeth / 2 * math.cos(ALPHA),
            }
        ), part
        # the reference circles look unlike the cut contours (ACI 8, 9: grey)
        colour = {layer.dxf.name: layer.dxf.color for layer in doc.layers}
        assert {colour["PITCH_CIRCLE"], colour["BASE_CIRCLE"]} == {8, 9}
        assert colour["PROFILE"] not in (8, 9) and colour[next(iter(cut))] not in (8, 9)


_LIBRECAD = shutil.which("librecad") and shutil.which("pdftoppm")


@pytest.mark.slow
@pytest.mark.skipif(not _LIBRECAD, reason="needs LibreCAD (apt-get install librecad) and pdftoppm")
def test_librecad_prints_the_gears_at_true_size(dxf_dir, tmp_path):
    """LibreCAD's own reader (libdxfrw) prints each file at 1:1: the ink spans the outline's box.

    The PDF is rasterised at 254 dpi (10 pixels a millimetre); the drawn
    extent is the box of the outermost contour, read here from the DXF.
    """
    from PIL import Image

    parts = ["pinion", "wheel", "crank_gear", "crankshaft", "wheel_bearing", "crank_bearing"]
    for part in parts:
        (tmp_path / f"{part}.dxf").write_bytes((dxf_dir / f"{part}.dxf").read_bytes())
    env = {**os.environ, "QT_QPA_PLATFORM": "offscreen", "XDG_RUNTIME_DIR": str(tmp_path)}
    r = subprocess.run(
        ["librecad", "dxf2pdf", "-s", "1", "-c", "-m", *(f"{p}.dxf" for p in parts)],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert r.returncode == 0, r.stderr
    for part in parts:
        subprocess.run(
            ["pdftoppm", "-png", "-r", "254", "-singlefile", f"{part}.pdf", part],
            cwd=tmp_path,
            check=True,
        )
        ink = np.array(Image.open(tmp_path / f"{part}.png").convert("L")) < 128
        rows, cols = np.nonzero(ink)
        drawn = np.array([np.ptp(cols), np.ptp(rows)]) / 10.0  # mm
        doc = ezdxf.readfile(tmp_path / f"{part}.dxf")
        msp = doc.modelspace()
        polylines = msp.query("LWPOLYLINE")
        outer = max(
            c.dxf.radius
            for c in msp.query("CIRCLE")
            if c.dxf.layer not in ("PITCH_CIRCLE", "BASE_CIRCLE")
        )
        want = np.array([2 * outer, 2 * outer])
        if polylines:
            p = np.array([v[:2] for v in polylines[0].get_points()])
            want = np.maximum(want, np.ptp(p, axis=0))
        assert drawn == pytest.approx(want, abs=0.3), part
