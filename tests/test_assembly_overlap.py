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


def _gear_contacts(scene) -> dict:
    """The first stage's meshing teeth: both outlines within the chord tolerance, so a
    tangent contact may show the lens of a 2 tol penetration over the face width."""
    if scene.first_stage is None:
        return {}
    dpen = 2.0 * scene.chord_tolerance
    fs = scene.first_stage
    lens = 4.0 / 3.0 * dpen * math.sqrt(2.0 * fs.crank_gear.root_radius * dpen)
    lens *= fs.stage.face_width
    return {("crank_gear", "wheel_"): lens, ("pinion", "wheel_"): lens}


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
        checked, overlaps = mesh.solid_overlaps(
            placed, fit_allowance_mm3=fit, contacts=_gear_contacts(scene)
        )
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


def _with_bearings(template: str, folder: Path, crank: str = ""):
    """The template on the drive model with both cams on needle bearings (the needles the
    cam's bore takes: 6 mm x the face width, as many as fit, at most 40); ``crank``: the
    crank model's sections added (the formats its solves refuse left out)."""
    lines = (ROOT / "templates" / template).read_text().splitlines()
    if crank:  # and the Monte Carlo's gates, which would ask for it
        lines = [x if not x.startswith("formats") else 'formats = ["dxf"]' for x in lines]
        lines = [x for x in lines if not x.startswith(("max_binding_prob", "max_failure_prob"))]
    text = "\n".join(x for x in lines if not x.startswith("load_share")) + "\n"
    drive = '[solver]\nmodel = "drive"\n'
    text = text.replace("[solver]\n", drive) if "[solver]\n" in text else text + "\n" + drive
    import tomllib

    plain = load_scene(ROOT / "templates" / template).design
    rp = plain.cam_bore_radius - 3.0
    n = min(40, math.ceil(math.pi / math.asin(6.0 / (2.0 * rp))) - 2)
    # A template's [life] rates its own needles: the drive's bearing is those needles.
    life = tomllib.loads(text).get("life", {})
    n, dia = life.get("needles", n), life.get("needle_diameter", 6.0)
    length = life.get("needle_length", plain.face_width)
    text += (
        f"\n[bearings.eccentric]\nneedles = {n}\nneedle_diameter = {dia}\n"
        f"needle_length = {length}\ndiametral_clearance = 0.005\n"
    )
    text += crank
    path = folder / template
    path.write_text(text)
    return load_scene(path)


#: The crank model's sections: its derived shaft on derived bearings, and a slender
#: hollow shaft on bearings of the scene's width whose crank gear sits farther out.
CRANKS = {
    "derived": "",
    "model": "\n[bearings.crank]\n",
    "slender": "\n[crankshaft]\nshaft_diameter = 40.0\nbore_diameter = 12.0\n"
    "gear_position = -60.0\n[bearings.crank]\nwidth = 14.0\n",
}


@pytest.mark.slow
@pytest.mark.parametrize("crank", CRANKS)
@pytest.mark.parametrize("template", TEMPLATES)
def test_no_two_solids_intersect_with_the_cams_on_needle_bearings(template, crank, tmp_path):
    """Every bundled template as a drive with bearings: the needles, the crankshaft with its
    eccentrics and seats (the crank model's, derived or given, carrying the first stage's
    crank gear with ``[first_stage]``), the support bearings and every other solid, every
    pair at 10 crank angles; a needle on its races within the tessellation's lens."""
    from corr_cad.geometry.profile import undercut_analysis, working_profile
    from corr_cad.run.stages import stages_bearing_parts, stages_first_stage
    from corr_cad.run.stages.stages_geometry import _placed_solids

    scene = _with_bearings(template, tmp_path, CRANKS[crank])
    if crank == "derived":
        assert scene.crank is None
    else:
        assert scene.crank is not None
    rows = stages_bearing_parts.needle_rows_of(scene)
    assert rows is not None
    d, tol = scene.design, scene.chord_tolerance
    working = working_profile(d, undercut_analysis(d))
    solids = {n: mesh.solid(o) for n, o in part_outlines(d, working, tol, floating=True).items()}
    ctx = SimpleNamespace(
        scene=scene, results=SimpleNamespace(gear_outlines=None, first_stage_solids=None)
    )
    extra = stages_first_stage.solids(ctx, {}) if scene.first_stage is not None else {}
    extra.update(stages_bearing_parts.solids(ctx, rows, {}))
    ctx.results.first_stage_solids = extra
    contacts = stages_bearing_parts.contact_allowances(d, rows, tol)
    contacts = {**contacts, **_gear_contacts(scene)}
    stack = mesh.frame_stack(d, solids["frame"])
    for k in range(10):
        angle = 36.0 * k + 3.7
        placed, _ = _placed_solids(ctx, solids, angle, stack=stack)
        assert sum(name.startswith("needle_") for name in placed) == 2 * rows[0].needles
        assert "crankshaft" in placed
        checked, overlaps = mesh.solid_overlaps(placed, contacts=contacts)
        n = len(placed)
        contacts_by_design = sum(
            1 for a in placed for b in placed if a < b and mesh._is_contact(a, b)
        )
        assert checked == n * (n - 1) // 2 - contacts_by_design
        assert not overlaps, (template, angle, overlaps[:3])
