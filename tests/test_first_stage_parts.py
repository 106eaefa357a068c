"""The first stage's parts in the assembly: phases, ratio by kinematics, no interference."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.first_stage import FirstStage, first_stage_geometry
from corr_cad.geometry.first_stage_parts import (
    FITS,
    first_stage_outlines,
    first_stage_placements,
    gear_phases,
)
from corr_cad.geometry.gear_outline import approximate_gear
from corr_cad.geometry.placement import assembly_placements

DESIGN = GearDesign()
FS = first_stage_geometry(
    FirstStage(
        18, 36, 90, 1.5, 15.0, shift_pinion=0.5, shift_crank_gear=0.5, backlash_allowance=0.03
    )
)
ANGLES_DEG = np.linspace(0.0, 360.0, 10, endpoint=False) + 3.7  # ten crank angles


def _by_name(placements):
    return {p.name: p for p in placements}


def test_total_ratio_by_kinematics():
    """Turn the crank a little: the pinion turns i1 (z + 1) times the frame."""
    d = 1e-4
    p0 = _by_name(first_stage_placements(DESIGN, FS, 0.0))["pinion"].angle_rad
    p1 = _by_name(first_stage_placements(DESIGN, FS, d))["pinion"].angle_rad
    f0 = _by_name(assembly_placements(DESIGN, 0.0))["frame_1"].angle_rad
    f1 = _by_name(assembly_placements(DESIGN, d))["frame_1"].angle_rad
    assert (p1 - p0) / (f1 - f0) == pytest.approx(-5.0 * 26, rel=1e-9)
    # the crank (and the crank gear) by 1/i1 of the pinion, each wheel by -z_p/z_w
    q0, q1 = (_by_name(first_stage_placements(DESIGN, FS, a)) for a in (0.0, d))
    assert (q1["crankshaft"].angle_rad - q0["crankshaft"].angle_rad) / (p1 - p0) == (
        pytest.approx(-1 / 5, rel=1e-9)
    )
    assert (q1["crank_gear"].angle_rad - q0["crank_gear"].angle_rad) / (p1 - p0) == (
        pytest.approx(-1 / 5, rel=1e-9)
    )
    for k in (1, 2, 3):
        dw = q1[f"wheel_{k}"].angle_rad - q0[f"wheel_{k}"].angle_rad
        assert dw / (p1 - p0) == pytest.approx(-18 / 36, rel=1e-9)


@pytest.mark.parametrize("zp,zw,zc", [(18, 36, 90), (16, 29, 74), (20, 34, 88), (17, 25, 67)])
def test_all_three_wheels_mesh_with_the_crank_gear(zp, zw, zc):
    fs = first_stage_geometry(
        FirstStage(zp, zw, zc, 1.0, 10.0, shift_pinion=0.5, shift_crank_gear=0.5)
    )
    for pinion in (0.0, 0.3, -2.0):
        gear_phases(fs, pinion)  # raises if the wheels disagree


def _polygons(angle_deg):
    """The gears' outline polygons placed in the gear plane."""
    verts = {
        k: approximate_gear(getattr(FS, k), 0.001).vertices
        for k in ("pinion", "wheel", "crank_gear")
    }
    out = {}
    for p in first_stage_placements(DESIGN, FS, math.radians(angle_deg)):
        if p.part not in verts:
            continue
        c, s = math.cos(p.angle_rad), math.sin(p.angle_rad)
        v = verts[p.part]
        # polar angles grow clockwise: (x, y) -> (x c + y s, -x s + y c)
        xy = np.stack([v[:, 0] * c + v[:, 1] * s, -v[:, 0] * s + v[:, 1] * c], axis=1)
        out[p.name] = xy + np.array(p.offset[:2])
    return out


@pytest.mark.parametrize("angle", ANGLES_DEG[:4])
def test_gear_meshes_keep_backlash_at_every_angle(angle):
    """Exact 2D clearance: each wheel clears the pinion and the crank gear's teeth, by less
    than the mesh's circumferential backlash (the teeth are in mesh, not apart)."""
    g = _polygons(angle)
    pinion = shapely.Polygon(g["pinion"])
    ring_hole = shapely.Polygon(g["crank_gear"])  # the space inside the internal teeth
    for k in (1, 2, 3):
        wheel = shapely.Polygon(g[f"wheel_{k}"])
        assert not wheel.intersects(pinion) and wheel.within(ring_hole)
        gap_p = wheel.distance(pinion)
        gap_c = wheel.exterior.distance(ring_hole.exterior)
        assert 0 < gap_p < FS.backlash[0] and 0 < gap_c < FS.backlash[1]


@pytest.mark.slow
def test_assembly_at_ten_angles_free_of_interference():
    """manifold3d booleans: every first-stage instance against every other instance of the
    drive, but the fits (bearing in bore, crank gear on its flange, cams on the shaft)."""
    from corr_cad.export import mesh
    from corr_cad.geometry.parts import part_outlines
    from corr_cad.geometry.profile import working_profile

    tol = 0.01
    verts = {
        k: approximate_gear(getattr(FS, k), tol).vertices for k in ("pinion", "wheel", "crank_gear")
    }
    first = {
        k: mesh.stacked_solid(v) for k, v in first_stage_outlines(DESIGN, FS, verts, tol).items()
    }
    second = {
        k: mesh.solid(o) for k, o in part_outlines(DESIGN, working_profile(DESIGN), tol).items()
    }
    worst = 0.0
    for angle in ANGLES_DEG:
        a = math.radians(angle)
        placed = mesh.assembly(DESIGN, second, a).all_solids()
        mine = {p.name: mesh.place(first[p.part], p) for p in first_stage_placements(DESIGN, FS, a)}
        everything = {**placed, **mine}
        boxes = {k: np.array(v.bounding_box()).reshape(2, 3) for k, v in everything.items()}
        for n1, s1 in mine.items():
            for n2, s2 in everything.items():
                if n1 >= n2 and n2 in mine:
                    continue
                if n1 == n2 or any(
                    (n1.startswith(x) and n2.startswith(y))
                    or (n1.startswith(y) and n2.startswith(x))
                    for x, y in FITS
                ):
                    continue
                b1, b2 = boxes[n1], boxes[n2]
                if np.any(b1[1] <= b2[0]) or np.any(b2[1] <= b1[0]):
                    continue
                v = (s1 ^ s2).volume()
                worst = max(worst, v)
                assert v < 1e-6, (angle, n1, n2, v)
    assert worst < 1e-6


def test_mesh_clearance_agrees_with_shapely_distances():
    """The run's clearance (local vertex-to-segment) equals shapely's polygon distance."""
    from corr_cad.geometry.first_stage_parts import mesh_clearance

    verts = {
        k: approximate_gear(getattr(FS, k), 0.001).vertices
        for k in ("pinion", "wheel", "crank_gear")
    }
    got = mesh_clearance(DESIGN, FS, verts, positions=3)
    pitch = 2 * math.pi / 18
    g1, g2 = math.inf, math.inf
    for j in range(3):
        pinion = j * pitch / 3
        crank_rad = pinion / FS.ratio  # the pinion angle i1 times the crank's
        crank_deg = math.degrees(crank_rad / (1 + 1 / 25))  # relative to the frame
        g = _polygons(crank_deg)
        pin, ring = shapely.Polygon(g["pinion"]), shapely.Polygon(g["crank_gear"])
        for k in (1, 2, 3):
            w = shapely.Polygon(g[f"wheel_{k}"])
            g1 = min(g1, w.distance(pin))
            g2 = min(g2, w.exterior.distance(ring.exterior))
    assert got["ok"]
    assert got["pinion_wheel_min_gap_mm"] == pytest.approx(g1, abs=1e-9)
    assert got["wheel_crank_gear_min_gap_mm"] == pytest.approx(g2, abs=1e-9)
