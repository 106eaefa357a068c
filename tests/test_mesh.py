"""Solids and meshes: watertight parts, exact volumes, round trips, interference."""

import json

import numpy as np
import pytest
import trimesh

from corr_cad import GearDesign, working_profile
from corr_cad.export import mesh
from corr_cad.geometry.parts import part_outlines
from corr_cad.run.folder.outputs import StagingDir
from corr_cad.run.pipeline import interference_allowance, run_scene
from corr_cad.run.scene.scene import parse_scene

TOL = 1e-3


@pytest.fixture(scope="module")
def built():
    design = GearDesign()
    outlines = part_outlines(design, working_profile(design), TOL)
    solids = {k: mesh.solid(v) for k, v in outlines.items()}
    return design, outlines, solids


@pytest.mark.parametrize("part", ["ring", "cam", "roller", "frame"])
def test_parts_are_closed_solids_with_exact_volume(built, part):
    design, outlines, solids = built
    tm = mesh.to_trimesh(solids[part])
    facts = mesh.check_mesh(tm, part)
    assert tm.is_watertight and tm.is_winding_consistent and tm.is_volume
    assert facts["volume_mm3"] > 0
    # Every boundary point within TOL of the exact curve: |dV| <= TOL x length x height.
    o = outlines[part]
    assert abs(tm.volume - o.exact_volume) <= TOL * o.boundary_length * o.thickness
    # Components: one connected solid per part.
    assert len(tm.split(only_watertight=False)) == 1


def test_exact_volumes_independently(built):
    design, outlines, _ = built
    import math

    assert outlines["roller"].exact_volume == pytest.approx(
        # Through the outer plate and half the middle one, less half the 0.2 mm end gap.
        math.pi * 8**2 * (12 + 1.5 * design.frame_thickness - 0.1)
    )
    ring_area = math.pi * design.ring_outer_radius**2 - working_profile(design).area()
    assert outlines["ring"].exact_volume == pytest.approx(ring_area * design.face_width)


#: Length of one file unit in mm: glTF is in metres, the others in millimetres.
FILE_UNIT_MM = {"stl": 1.0, "3mf": 1.0, "glb": 1000.0, "ply": 1.0}


@pytest.mark.parametrize("fmt", ["stl", "3mf", "glb", "ply"])
def test_round_trip_through_trimesh(built, tmp_path, fmt):
    _, _, solids = built
    tm = mesh.to_trimesh(solids["ring"])
    path = mesh.write_mesh(tm, tmp_path / f"ring.{fmt}", fmt)
    back = trimesh.load(path, force="mesh")
    back.merge_vertices()
    assert back.is_watertight
    # Outward normals: consistent winding and a positive volume, in every format.
    assert back.is_winding_consistent and back.volume > 0
    k = FILE_UNIT_MM[fmt]
    assert back.volume * k**3 == pytest.approx(tm.volume, rel=1e-6)
    np.testing.assert_allclose(back.bounds * k, tm.bounds, atol=1e-4)


def test_glb_is_in_metres_and_3mf_says_millimetres(built, tmp_path):
    import zipfile

    _, outlines, solids = built
    tm = mesh.to_trimesh(solids["roller"])
    glb = trimesh.load(mesh.write_mesh(tm, tmp_path / "r.glb", "glb"), force="mesh")
    # The roller is 8 mm in radius: 0.008 in the file.
    assert glb.bounds[1, 0] == pytest.approx(0.008, rel=1e-6)
    path = mesh.write_mesh(tm, tmp_path / "r.3mf", "3mf")
    with zipfile.ZipFile(path) as z:
        model = z.read("3D/3dmodel.model").decode()
    assert 'unit="millimeter"' in model
    back = trimesh.load(path, force="mesh")
    assert back.bounds[1, 0] == pytest.approx(8.0, rel=1e-6)


@pytest.mark.slow
def test_assembly_round_trip_keeps_named_parts(built, tmp_path):
    design, _, solids = built
    asm = mesh.assembly(design, solids, 0.0)
    parts = {k: mesh.to_trimesh(v) for k, v in asm.all_solids().items()}
    assert len(parts) == 7 + 2 * design.roller_count
    for fmt in ("glb", "3mf"):
        path = mesh.write_mesh(parts, tmp_path / f"a.{fmt}", fmt)
        scene = trimesh.load(path)
        assert set(scene.geometry) == set(parts)
        k = FILE_UNIT_MM[fmt]
        for name, geom in scene.geometry.items():
            # Every part closed, outward wound, in place.
            assert geom.is_winding_consistent and geom.volume > 0, (fmt, name)
            assert geom.volume * k**3 == pytest.approx(parts[name].volume, rel=1e-6)
            np.testing.assert_allclose(geom.bounds * k, parts[name].bounds, atol=1e-4)
    for fmt in ("stl", "ply"):
        back = trimesh.load(mesh.write_mesh(parts, tmp_path / f"a.{fmt}", fmt), force="mesh")
        assert back.volume == pytest.approx(sum(p.volume for p in parts.values()), rel=1e-6)


def test_assembly_places_rollers_on_cam_and_gear(built):
    # Every roller touches cam A and ring A: gaps within the tessellation allowance.
    design, _, solids = built
    asm = mesh.assembly(design, solids, np.radians(33.0))
    allow = interference_allowance(design, TOL)
    for i in (0, 5, 11):
        r = asm.rollers_a[i]
        assert r.min_gap(asm.parts["cam_a"], 0.5) <= allow["cam"]["gap_mm"]
        assert r.min_gap(asm.parts["ring_a"], 0.5) <= allow["ring"]["gap_mm"]
        # Row B rollers are 180 deg out of phase: on their own cam and ring.
        rb = asm.rollers_b[i]
        assert rb.min_gap(asm.parts["cam_b"], 0.5) <= allow["cam"]["gap_mm"]
        assert rb.min_gap(asm.parts["ring_b"], 0.5) <= allow["ring"]["gap_mm"]


def _interference(tmp_path, **errors):
    data = {
        "export": {
            "formats": ["interference"],
            "interference_method": "mesh",
            "interference_positions": 4,
        },
        "errors": errors,
    }
    out = tmp_path / "o"
    with StagingDir(out) as stage:
        run_scene(parse_scene(data, "i"), stage)
    return json.loads((out / "manifest.json").read_text())["interference"], out


@pytest.mark.slow
def test_nominal_assembly_has_no_interference_over_a_cycle(tmp_path):
    summary, out = _interference(tmp_path)
    assert summary["ok"] and summary["violations"] == 0
    lines = (out / "interference.csv").read_text().splitlines()
    assert len(lines) == 1 + 4 * 2 * 26
    for part, v in summary["max_volume_mm3"].items():
        assert v <= summary["allowance"][part]["volume_mm3"]


@pytest.mark.slow
def test_oversized_roller_shows_interference_where_expected(tmp_path):
    per = [0.0] * 26
    per[2] = 0.05  # roller 3 is 0.05 mm oversize
    summary, out = _interference(tmp_path, roller_radius_errors=per)
    assert not summary["ok"]
    rows = [line.split(",") for line in (out / "interference.csv").read_text().splitlines()[1:]]
    bad = {
        (r[1], int(r[2])) for r in rows if float(r[3]) > summary["allowance"]["ring"]["volume_mm3"]
    }
    assert bad == {("a", 3), ("b", 3)}  # in both rows, and only roller 3
    cam_bad = {
        (r[1], int(r[2])) for r in rows if float(r[5]) > summary["allowance"]["cam"]["volume_mm3"]
    }
    assert cam_bad == {("a", 3), ("b", 3)}
    # The oversize roller also jams its frame slot (width 2r).
    assert (
        max(float(r[7]) for r in rows if int(r[2]) == 3)
        > summary["allowance"]["frame"]["volume_mm3"]
    )
    # At every crank position.
    assert {float(r[0]) for r in rows if int(r[2]) == 3 and float(r[3]) > 0.01} == {
        0.0,
        90.0,
        180.0,
        270.0,
    }


@pytest.mark.slow
def test_undersized_rollers_open_gaps(tmp_path):
    summary, _ = _interference(tmp_path, roller_radius_error=-0.02)
    assert not summary["ok"]
    assert summary["max_gap_mm"]["ring"] >= 0.02


#: The STEP assembly's instance names (docs/outputs.md): every part its own node.
STEP_NAMES = ["ring_a", "ring_b", "cam_a", "cam_b", "frame_1", "frame_2", "frame_3"] + [
    f"roller_{row}_{i:02d}" for row in "ab" for i in range(1, 27)
]


def _glb_nodes(path):
    """Node names from the GLB's own JSON chunk (header, then a JSON chunk; glTF 2.0)."""
    import struct

    data = path.read_bytes()
    length, kind = struct.unpack_from("<II", data, 12)
    assert kind == 0x4E4F534A  # "JSON"
    gltf = json.loads(data[20 : 20 + length])
    return [n["name"] for n in gltf["nodes"] if "mesh" in n], gltf


def test_assembly_files_have_one_named_node_per_frame_plate(tmp_path):
    """GLB and 3MF: each of the three frame plates is its own node, named as in STEP."""
    data = {"export": {"formats": ["glb", "3mf"], "chord_tolerance": 0.01}}
    out = tmp_path / "o"
    with StagingDir(out) as stage:
        run_scene(parse_scene(data, "a"), stage)
    names, _ = _glb_nodes(out / "assembly_000deg.glb")
    assert sorted(names) == sorted(STEP_NAMES)
    threemf = trimesh.load(out / "assembly_000deg.3mf")
    assert sorted(threemf.geometry) == sorted(STEP_NAMES)
    glb = trimesh.load(out / "assembly_000deg.glb")
    d = GearDesign()
    w, t = d.face_width, d.frame_thickness
    plate = trimesh.load(out / "teeth_frame.3mf", force="mesh")
    for k, z0 in ((1, -t), (2, w), (3, 2 * w + t)):
        one = threemf.geometry[f"frame_{k}"]
        # one plate each, where the layout puts it (mm in 3MF, metres in GLB)
        assert one.volume == pytest.approx(plate.volume, rel=1e-9)
        np.testing.assert_allclose(one.bounds[:, 2], [z0, z0 + t], atol=1e-9)
        placed = glb.graph.get(f"frame_{k}")[0] @ np.r_[0.0, 0.0, 0.0, 1.0]
        bounds = glb.geometry[glb.graph.get(f"frame_{k}")[1]].bounds
        np.testing.assert_allclose((bounds[:, 2] + placed[2]) * 1000.0, [z0, z0 + t], atol=1e-6)


def test_3mf_is_deflated_once_to_the_bytes_of_trimesh_s_own_archive(built, tmp_path):
    """write_mesh deflates the 3MF once; trimesh's deflated archive, made stable, is the same."""
    import zipfile

    _, _, solids = built
    tm = mesh.to_trimesh(solids["roller"])
    path = mesh.write_mesh(tm, tmp_path / "r.3mf", "3mf")
    reference = mesh.stable_3mf(tm.export(file_type="3mf"))  # trimesh deflates (level 5)
    assert path.read_bytes() == reference
    with zipfile.ZipFile(path) as z:
        assert {i.compress_type for i in z.infolist()} == {zipfile.ZIP_DEFLATED}


def test_3mf_of_an_assembly_is_trimesh_s_own_archive_byte_for_byte(built, tmp_path):
    """The 3MF of a scene of named parts (vertices handed to trimesh's writer as Python
    floats) is trimesh's own archive, made stable: the same text for every coordinate."""
    import trimesh

    _, _, solids = built
    parts = {name: mesh.to_trimesh(solids[name]) for name in ("roller", "cam")}
    parts["roller"].apply_translation([0.1, -1e-7, 3.0e5])  # exponents, tiny and large values
    path = mesh.write_mesh(parts, tmp_path / "a.3mf", "3mf")
    scene = trimesh.Scene()
    for name, m in parts.items():
        scene.add_geometry(m, node_name=name, geom_name=name)
    assert path.read_bytes() == mesh.stable_3mf(scene.export(file_type="3mf"))
