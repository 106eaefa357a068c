"""No two solids of a bundled template's assembly intersect, the two rows' rollers included.

Every pair of placed solids at 10 crank angles, intersected with manifold3d
(pairs whose bounding boxes are apart cannot intersect); the contacts a
roller makes by design (its ring, its cam, the frame plates) are checked
against the tessellation allowance by the interference stage and are left
out here. The axial layout puts each roller within its half of the middle
plate (``corr_cad.geometry.parts.roller_z_range``).
"""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import pytest

from corr_cad.export import mesh
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.parts import part_outlines, roller_solid_length, roller_z_range
from corr_cad.run.scene.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]
TEMPLATES = sorted(p.name for p in (ROOT / "templates").glob("*.toml"))


def _assembly_solids(scene) -> tuple[dict, object]:
    """The part solids (second stage and, with ``[first_stage]``, the first) and a ctx."""
    from corr_cad.geometry.profile import undercut_analysis, working_profile

    d = scene.design
    tol = scene.chord_tolerance
    working = working_profile(d, undercut_analysis(d))
    solids = {name: mesh.solid(o) for name, o in part_outlines(d, working, tol).items()}
    ctx = SimpleNamespace(scene=scene, results=SimpleNamespace(gear_outlines=None))
    first = {}
    if scene.first_stage is not None:
        from corr_cad.run.stages import stages_first_stage

        first = stages_first_stage.solids(ctx, {})
    return solids, first, ctx


@pytest.mark.slow
@pytest.mark.parametrize("template", TEMPLATES)
def test_no_two_solids_intersect(template):
    scene = load_scene(ROOT / "templates" / template)
    solids, first, ctx = _assembly_solids(scene)
    stack = mesh.frame_stack(scene.design, solids["frame"])
    for k in range(10):
        angle = 36.0 * k + 3.7  # off the symmetric positions
        asm = mesh.assembly(scene.design, solids, math.radians(angle), stack=stack)
        placed = asm.all_solids()
        if first:
            from corr_cad.run.stages.stages_first_stage import placements

            placed.update({p.name: mesh.place(first[p.part], p) for p in placements(ctx, angle)})
        # A cam's bore on the crankshaft: both circles inscribed polygons, a
        # sliver at most chord_tolerance deep over the bore's face.
        d = scene.design
        fit = scene.chord_tolerance * 2 * math.pi * d.cam_bore_radius * d.face_width
        checked, overlaps = mesh.solid_overlaps(placed, fit_allowance_mm3=fit)
        n = len(placed)
        contacts = sum(1 for a in placed for b in placed if a < b and mesh._is_contact(a, b))
        assert checked == n * (n - 1) // 2 - contacts
        assert not overlaps, (template, angle, overlaps[:3])


def test_the_two_rows_rollers_once_overlapped_and_are_found():
    """The check finds the overlap the old layout had (each roller w + 2 t long from z = -t / w)."""
    d = GearDesign()
    w, t = d.face_width, d.frame_thickness
    import manifold3d as m3d

    old = m3d.Manifold.cylinder(w + 2 * t, d.roller_radius, d.roller_radius, 64)
    solids = {"roller_a_01": old.translate((0, 140, -t)), "roller_b_01": old.translate((0, 141, w))}
    checked, overlaps = mesh.solid_overlaps(solids)
    assert checked == 1 and len(overlaps) == 1 and overlaps[0]["volume_mm3"] > 100.0


def test_roller_layout_by_hand():
    """The prototype (w = 12, t = 8): row A [-8, 15.9], row B [16.1, 40], 23.9 mm long."""
    d = GearDesign()
    assert roller_solid_length(d) == pytest.approx(12 + 1.5 * 8 - 0.1, abs=1e-12)
    assert roller_z_range(d, "a") == pytest.approx((-8.0, 15.9), abs=1e-12)
    assert roller_z_range(d, "b") == pytest.approx((16.1, 40.0), abs=1e-12)
    # Each ends within its half of the middle plate [w, w + t] = [12, 20].
    assert 12.0 < roller_z_range(d, "a")[1] < 16.0 < roller_z_range(d, "b")[0] < 20.0
