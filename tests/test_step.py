"""STEP AP214 export, run as a user runs it, read back by Open CASCADE.

The reference values are computed here from the paper's closed form and
share no code with the exporter: the roller-centre locus
``s = e cos(psi) + sqrt(L^2 - e^2 sin^2 psi)``, ``L = Rj + r``,
``psi = z t`` at ``s (sin t, cos t)``; the working profile is its outer
offset by ``r``, whose area and length follow from the locus by Steiner's
formula (``A + r P + pi r^2`` and ``P + 2 pi r``, valid without undercut).
"""

import builtins
import json
import math
import os
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

from corr_cad import ExportError

step = pytest.importorskip("corr_cad.export.step")
pytest.importorskip("OCP")

TOL = 1e-3
SLOT_END = 1.0  # mm, the frame slot's end clearance (README, "Solids, meshes and STEP")

# Two designs: the paper's prototype, and a z = 39 drive at 0.996 of its
# undercut limit (tooth tip radius 0.02 mm).
DESIGNS = {
    "prototype": dict(tooth_count=25, cam_radius=135.0, roller_radius=8.0, eccentricity=3.5),
    "z39": dict(tooth_count=39, cam_radius=150.0, roller_radius=5.35, eccentricity=3.0),
}
SIZES = dict(
    roller_length=12.0,
    face_width=12.0,
    ring_outer_radius=180.0,
    cam_bore_radius=40.0,
    frame_inner_radius=100.0,
    frame_outer_radius=172.0,
    frame_thickness=6.0,
)
ANGLE = {"prototype": 33.0, "z39": 0.0}


def _scene(name: str) -> str:
    d = {**DESIGNS[name], **SIZES}
    lines = ["[design]"] + [f"{k} = {v}" for k, v in d.items()]
    lines += [
        "[export]",
        'formats = ["step", "dxf"]',
        'representation = "spline"',
        f"tolerance = {TOL}",
        f"assembly_angles_deg = [{ANGLE[name]}]",
    ]
    return "\n".join(lines) + "\n"


@pytest.fixture(scope="module", params=list(DESIGNS))
def run(request, tmp_path_factory):
    """``corr-cad run`` in a fresh process, into a folder that holds another file."""
    name = request.param
    folder = tmp_path_factory.mktemp(name)
    (folder / "notes.txt").write_text("not ours")
    scene = folder / f"{name}.toml"
    scene.write_text(_scene(name))
    out = folder / "out"
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(out)],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    assert (folder / "notes.txt").read_text() == "not ours"
    manifest = json.loads((out / "manifest.json").read_text())
    return name, {**DESIGNS[name], **SIZES}, out, manifest


# --- the exact geometry, from the closed form --------------------------------
def _locus(d, n=200_000):
    """Polar radius s(t) and ds/dt of the roller-centre locus on a uniform t grid."""
    z, e, r = d["tooth_count"], d["eccentricity"], d["roller_radius"]
    L = d["cam_radius"] + r
    t = np.arange(n) * 2 * np.pi / n
    psi = z * t
    root = np.sqrt(L * L - (e * np.sin(psi)) ** 2)
    s = e * np.cos(psi) + root
    ds = z * (-e * np.sin(psi) - e * e * np.sin(psi) * np.cos(psi) / root)
    return t, s, ds


def exact_profile_area_and_length(d):
    """Area enclosed by the working profile and its length (trapezoid: periodic, spectral)."""
    t, s, ds = _locus(d)
    dt = 2 * np.pi / len(t)
    area0 = 0.5 * np.sum(s * s) * dt
    length0 = np.sum(np.sqrt(s * s + ds * ds)) * dt
    r = d["roller_radius"]
    return area0 + r * length0 + np.pi * r * r, length0 + 2 * np.pi * r


def exact_working_points(d, n=400_000):
    t, s, ds = _locus(d, n)
    p = s[:, None] * np.stack([np.sin(t), np.cos(t)], 1)
    dp = ds[:, None] * np.stack([np.sin(t), np.cos(t)], 1) + s[:, None] * np.stack(
        [np.cos(t), -np.sin(t)], 1
    )
    # t runs clockwise: the outward normal is the tangent turned counter-clockwise.
    nrm = np.stack([-dp[:, 1], dp[:, 0]], 1) / np.linalg.norm(dp, axis=1)[:, None]
    return p + d["roller_radius"] * nrm


def distance_to_polygon(q, poly):
    """Distance from points q to the closed dense polygon (two segments at the nearest vertex)."""
    from scipy.spatial import cKDTree

    _, i = cKDTree(poly).query(q)
    best = np.full(len(q), np.inf)
    for j0, j1 in ((i - 1, i), (i, (i + 1) % len(poly))):
        a, b = poly[j0], poly[j1]
        ab = b - a
        u = np.clip(np.sum((q - a) * ab, 1) / np.sum(ab * ab, 1), 0, 1)
        best = np.minimum(best, np.linalg.norm(q - (a + u[:, None] * ab), axis=1))
    return best


def exact_solids(d):
    """(volume, surface area) of each part file from the inputs alone."""
    w, t, r = d["face_width"], d["frame_thickness"], d["roller_radius"]
    Ro, Rj, rb = d["ring_outer_radius"], d["cam_radius"], d["cam_bore_radius"]
    Fi, Fo = d["frame_inner_radius"], d["frame_outer_radius"]
    a_prof, p_prof = exact_profile_area_and_length(d)
    ring_face = np.pi * Ro**2 - a_prof
    cam_face = np.pi * (Rj**2 - rb**2)
    # Through the outer plate and half the middle one, 0.1 mm (half the end gap
    # of min(0.2, t / 2)) short of its mid-plane.
    h_roll = w + 1.5 * t - 0.5 * min(0.2, 0.5 * t)
    slot_len = 2 * (d["eccentricity"] + SLOT_END)
    n_slots = d["tooth_count"] + 1
    frame_face = np.pi * (Fo**2 - Fi**2) - n_slots * (2 * r * slot_len + np.pi * r * r)
    frame_edges = 2 * np.pi * (Fo + Fi) + n_slots * (2 * np.pi * r + 2 * slot_len)
    return {
        "inner_gear": (ring_face * w, 2 * ring_face + w * (2 * np.pi * Ro + p_prof)),
        "disk_cam": (cam_face * w, 2 * cam_face + w * 2 * np.pi * (Rj + rb)),
        "roller": (np.pi * r * r * h_roll, 2 * np.pi * r * r + 2 * np.pi * r * h_roll),
        "teeth_frame": (frame_face * t, 2 * frame_face + t * frame_edges),
    }


_HEALED: dict = {}


def _read_healed(path):
    """The shape as FreeCAD gets it: STEPControl_Reader with its default healing."""
    if path in _HEALED:
        return _HEALED[path]
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader

    reader = STEPControl_Reader()
    assert reader.ReadFile(str(path)) == IFSelect_RetDone
    reader.TransferRoots()
    _HEALED[path] = reader.OneShape()
    return _HEALED[path]


# --- tests -------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("part", ["inner_gear", "disk_cam", "roller", "teeth_frame"])
def test_open_cascade_mass_properties_match_the_exact_solid(run, part):
    # GProp on the read-back shape, not a tessellation: what CAD programs report.
    name, d, out, manifest = run
    shape = _read_healed(out / f"{part}.step")
    volume, area = step.mass_properties(shape)
    exact_volume, exact_area = exact_solids(d)[part]
    assert volume == pytest.approx(exact_volume, rel=1e-5)
    assert area == pytest.approx(exact_area, rel=1e-5)
    facts = manifest["step"][f"{part}.step"]
    assert facts["readback_volume_mm3"] == pytest.approx(volume, rel=1e-12)
    assert facts["exact_volume_mm3"] == pytest.approx(exact_volume, rel=1e-9)


@pytest.mark.slow
def test_ring_face_area_from_open_cascade(run):
    # The planar face alone (the profile's enclosed area is what a shop measures).
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepGProp import BRepGProp
    from OCP.GeomAbs import GeomAbs_Plane
    from OCP.GProp import GProp_GProps
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    name, d, out, _ = run
    shape = _read_healed(out / "inner_gear.step")
    ring_face = np.pi * d["ring_outer_radius"] ** 2 - exact_profile_area_and_length(d)[0]
    areas = []
    exp = TopExp_Explorer(shape, TopAbs_FACE)
    while exp.More():
        face = step._static(TopoDS, "Face")(exp.Current())
        if BRepAdaptor_Surface(face).GetType() == GeomAbs_Plane:
            props = GProp_GProps()
            step._static(BRepGProp, "SurfaceProperties")(face, props)
            areas.append(props.Mass())
        exp.Next()
    assert len(areas) == 2
    for a in areas:
        assert a == pytest.approx(ring_face, rel=1e-5)


@pytest.mark.slow
def test_profile_edges_lie_on_the_exact_profile_and_join(run):
    name, d, out, manifest = run
    curves = step.read_step_curves(out / "inner_gear.step", samples_per_edge=24)
    z = d["tooth_count"]
    bottom = [c for c in curves if np.abs(c[:, 2]).max() <= 1e-9]
    top = [c for c in curves if np.abs(c[:, 2] - d["face_width"]).max() <= 1e-9]
    # Whole teeth: the same number of edges per tooth, on both faces.
    n_edges = manifest["step"]["inner_gear.step"]["profile_edges"]
    assert len(bottom) == len(top) == n_edges and n_edges % z == 0
    assert len(curves) == 2 * n_edges
    pts = np.vstack(bottom)
    dist = distance_to_polygon(pts[:, :2], exact_working_points(d))
    assert dist.max() <= TOL
    # Every edge end is another edge's start.
    starts = np.array([c[0, :2] for c in bottom])
    ends = np.array([c[-1, :2] for c in bottom])
    gap = np.min(np.linalg.norm(ends[:, None, :] - starts[None, :, :], axis=2), axis=1)
    assert gap.max() <= 1e-9


@pytest.mark.slow
def test_every_product_is_named_after_its_part(run):
    name, d, out, manifest = run
    for part in ("inner_gear", "disk_cam", "roller", "teeth_frame"):
        path = out / f"{part}.step"
        top, parts = step.read_step(path, heal=False)
        assert top == part and [(p.name, p.product) for p in parts] == [(part, part)]
        text = path.read_text(errors="replace")
        assert f"PRODUCT('{part}'" in text
        assert "Open CASCADE STEP translator" not in text
        assert "AUTOMOTIVE_DESIGN" in text  # AP214
        assert manifest["step"][f"{part}.step"]["product_name"] == part


def _expected_names(z):
    names = ["ring_a", "ring_b", "cam_a", "cam_b", "frame_1", "frame_2", "frame_3"]
    for row in "ab":
        names += [f"roller_{row}_{i:02d}" for i in range(1, z + 2)]
    return names


@pytest.mark.slow
def test_assembly_step_has_named_parts_where_the_mesh_assembly_has_them(run):
    from corr_cad.export import mesh
    from corr_cad.geometry.parts import part_outlines
    from corr_cad.geometry.profile import working_profile
    from corr_cad.run.scene.scene import parse_scene

    name, d, out, manifest = run
    tag = f"{int(ANGLE[name]):03d}deg"
    path = out / f"assembly_{tag}.step"
    top, parts = step.read_step(path, heal=False)
    z = d["tooth_count"]
    assert top == f"assembly_{tag}"
    assert [p.name for p in parts] == _expected_names(z)
    product = {"ring": "inner_gear", "cam": "disk_cam", "frame": "teeth_frame"}
    for p in parts:
        assert p.product == product.get(p.name.split("_")[0], "roller")
    boxes = {p.name: step.bounding_box(p.shape) for p in parts}

    # Independently: every roller centre at its crank-slider radius (closed form).
    c = math.radians(ANGLE[name])
    e, L = d["eccentricity"], d["cam_radius"] + d["roller_radius"]
    theta0 = c / z
    w, t = d["face_width"], d["frame_thickness"]
    # Row B's rollers start 0.1 mm past the middle plate's mid-plane (half
    # the end gap min(0.2, t / 2) between the two rows' rollers).
    for row, dphi, z0 in (("a", 0.0, -t), ("b", math.pi, w + t / 2 + min(0.1, t / 4))):
        for i in range(z + 1):
            theta = theta0 + 2 * math.pi * i / (z + 1)
            psi = c + theta0 + dphi - theta
            s = e * math.cos(psi) + math.sqrt(L * L - (e * math.sin(psi)) ** 2)
            centre = boxes[f"roller_{row}_{i + 1:02d}"].mean(axis=0)
            want = [s * math.sin(theta), s * math.cos(theta)]
            np.testing.assert_allclose(centre[:2], want, atol=1e-7)
            assert boxes[f"roller_{row}_{i + 1:02d}"][0, 2] == pytest.approx(z0, abs=1e-7)

    # Turns (invisible in a box for the rings and plates): where a marked point
    # (0, 100) of each part lands, from the README's layout.
    from OCP.gp import gp_Pnt

    def turned(a, p):  # polar angles grow by a
        return [p[0] * math.cos(a) + p[1] * math.sin(a), -p[0] * math.sin(a) + p[1] * math.cos(a)]

    phi = c + theta0
    want = {
        "ring_a": turned(0.0, (0, 100)) + [0.0],
        "ring_b": turned(math.pi / z, (0, 100)) + [w + t],
        "cam_a": turned(phi, (0, 100 + e)) + [0.0],
        "cam_b": turned(phi + math.pi, (0, 100 + e)) + [w + t],
        "frame_1": turned(theta0, (0, 100)) + [-t],
        "frame_2": turned(theta0, (0, 100)) + [w],
        "frame_3": turned(theta0, (0, 100)) + [2 * w + t],
    }
    for p in parts[:7]:
        q = gp_Pnt(0.0, 100.0, 0.0).Transformed(p.shape.Location().Transformation())
        np.testing.assert_allclose([q.X(), q.Y(), q.Z()], want[p.name], atol=1e-9)

    # Against the mesh assembly (polygons inscribed within TOL): the same boxes.
    scene = parse_scene({"design": d}, "x")
    outlines = part_outlines(scene.design, working_profile(scene.design), TOL)
    solids = {k: mesh.solid(v) for k, v in outlines.items()}
    asm = mesh.assembly(scene.design, solids, c).all_solids()
    # The same instance names, and each plate its own node (frame_1 to frame_3).
    assert set(asm) == {p.name for p in parts}
    for key, box in [(k, boxes[k]) for k in _expected_names(z)[:7]] + [
        ("roller_a_05", boxes["roller_a_05"]),
        ("roller_b_05", boxes["roller_b_05"]),
    ]:
        mesh_box = np.reshape(asm[key].bounding_box(), (2, 3))
        np.testing.assert_allclose(box, mesh_box, atol=2 * TOL)
    total = sum(step.mass_properties(p.shape)[0] for p in parts)
    vols = exact_solids(d)
    expected = 2 * vols["inner_gear"][0] + 2 * vols["disk_cam"][0] + 3 * vols["teeth_frame"][0]
    assert total == pytest.approx(expected + 2 * (z + 1) * vols["roller"][0], rel=1e-5)
    assert manifest["step"][f"assembly_{tag}.step"]["instances"] == len(parts)


@pytest.mark.slow
def test_assembly_freecad_variant_is_every_instance_as_a_named_solid(run):
    """``assembly_<angle>deg_freecad.step``: one product, one compound, a solid
    an instance where the assembly puts it, of the part's exact volume."""
    name, d, out, manifest = run
    tag = f"{int(ANGLE[name]):03d}deg"
    _, parts = step.read_step(out / f"assembly_{tag}.step", heal=False)
    path = out / f"assembly_{tag}_freecad.step"
    top, whole = step.read_step(path, heal=False)
    assert top == f"assembly_{tag}" and len(whole) == 1  # no assembly structure
    solids = step.read_solids(path, heal=False)
    assert len(solids) == len(parts)
    for solid, p in zip(solids, parts, strict=True):  # in the placements' order
        np.testing.assert_allclose(
            step.bounding_box(solid, optimal=False),
            step.bounding_box(p.shape, optimal=False),
            atol=1e-9,
        )
    # Each solid carries its instance's name in the file.
    names = re.findall(r"MANIFOLD_SOLID_BREP\('([^']*)'", path.read_text())
    assert names == _expected_names(d["tooth_count"])
    z, vols = d["tooth_count"], exact_solids(d)
    expected = 2 * vols["inner_gear"][0] + 2 * vols["disk_cam"][0] + 3 * vols["teeth_frame"][0]
    expected += 2 * (z + 1) * vols["roller"][0]
    total = sum(step.mass_properties(s)[0] for s in solids)
    assert total == pytest.approx(expected, rel=1e-5)
    facts = manifest["step"][f"assembly_{tag}_freecad.step"]
    assert facts["solids"] == len(parts)
    assert abs(facts["volume_relative_error"]) <= 1e-9
    assert f"assembly_{tag}_freecad.step" in manifest["files"]


def test_compound_writer_names_each_placed_solid(tmp_path):
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox

    from corr_cad.geometry.placement import Placement

    box = BRepPrimAPI_MakeBox(10.0, 10.0, 10.0).Shape()
    placements = [
        Placement("b1", "box", 0.0, np.zeros(3), np.zeros(2)),
        Placement("b2", "box", math.pi / 2, np.array([20.0, 0.0, 0.0]), np.zeros(2)),
    ]
    path = step.write_compound_step({"box": box}, placements, tmp_path / "c.step", "asm")
    assert step.read_step(path)[0] == "asm"
    solids = step.read_solids(path)
    assert [step.mass_properties(s)[0] for s in solids] == pytest.approx([1000.0, 1000.0])
    # b2 turned by -90 deg about z (polar angles clockwise), then moved 20 mm in x.
    np.testing.assert_allclose(
        step.bounding_box(solids[1]), [[20.0, -10.0, 0.0], [30.0, 0.0, 10.0]], atol=1e-7
    )
    assert re.findall(r"MANIFOLD_SOLID_BREP\('([^']*)'", path.read_text()) == ["b1", "b2"]


@pytest.mark.slow
def test_dxf_spline_is_one_c1_spline_per_tooth_with_the_exact_area(run):
    import ezdxf

    name, d, out, manifest = run
    doc = ezdxf.readfile(out / "inner_gear.dxf")
    splines = [e for e in doc.modelspace() if e.dxf.layer == "WORKING_PROFILE"]
    z = d["tooth_count"]
    assert len(splines) == z and all(e.dxftype() == "SPLINE" for e in splines)
    tools = [e.construction_tool() for e in splines]
    pts = []
    for i, tool in enumerate(tools):
        nxt = tools[(i + 1) % z]
        end, start = tool.control_points[-1], nxt.control_points[0]
        assert (end - start).magnitude <= 1e-9
        # C1: the same tangent direction on both sides of the join (smooth profile).
        t_end = tool.derivative(tool.max_t, 1)[1].normalize()
        t_start = nxt.derivative(0.0, 1)[1].normalize()
        assert (t_end - t_start).magnitude <= 1e-6
        u = np.linspace(0.0, tool.max_t, 4001)[:-1]
        pts.append(np.array([(p.x, p.y) for p in tool.points(u)]))
    p = np.vstack(pts)
    area = 0.5 * abs(np.dot(p[:, 0], np.roll(p[:, 1], -1)) - np.dot(p[:, 1], np.roll(p[:, 0], -1)))
    assert area == pytest.approx(exact_profile_area_and_length(d)[0], rel=1e-5)
    assert distance_to_polygon(p, exact_working_points(d)).max() <= TOL


def test_missing_extra_gives_install_hint(monkeypatch):
    real_import = builtins.__import__

    def no_ocp(name, *a, **k):
        if name == "OCP" or name.startswith("OCP."):
            raise ImportError("No module named 'OCP'")
        return real_import(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", no_ocp)
    with pytest.raises(ExportError, match=r"pip install -e '\.\[step\]'"):
        step.require_ocp()


@pytest.mark.parametrize("part", ["pinion", "crank_gear"])
def test_gear_tips_and_roots_are_exact_whole_arcs(part):
    """Each tooth's tip and root are one circle edge about the centre (not two
    B-spline halves); the tip edge spans the tooth's tip thickness, from the
    textbook: ``s_a = 2 r_a (s / 2r + inv(alpha) - inv(alpha_a))`` (for the
    internal gear, the pitch less its space, shaped like that tooth)."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.BRepCheck import BRepCheck_Analyzer
    from OCP.GeomAbs import GeomAbs_BSplineCurve, GeomAbs_Circle
    from OCP.OCP.collections import IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS

    from corr_cad.export import step_gears
    from corr_cad.geometry.first_stage import FirstStage, first_stage_geometry
    from corr_cad.geometry.gear_outline import spline_gear

    m, alpha, j, x = 1.5, math.radians(20.0), 0.03, 0.5
    geom = first_stage_geometry(
        FirstStage(18, 36, 90, m, 15.0, shift_pinion=x, shift_crank_gear=x, backlash_allowance=j)
    )
    g = getattr(geom, part)
    z, r, r_a = g.teeth, m * g.teeth / 2, g.tip
    alpha_a = math.acos(r * math.cos(alpha) / r_a)
    # the pinion's tooth, thinned by the allowance; the internal gear's space,
    # shaped like an external tooth, widened by it
    s = m * (math.pi / 2 + 2 * x * math.tan(alpha)) + (j if g.internal else -j)
    tooth_or_space = s / r + 2 * ((math.tan(alpha) - alpha) - (math.tan(alpha_a) - alpha_a))
    # the internal gear's tooth at its tip is the pitch less its space there
    tip_span = 2 * math.pi / z - tooth_or_space if g.internal else tooth_or_space
    outline = spline_gear(g, TOL)
    pieces = (
        [(g.root_radius + 5.0, [outline], 5.0, 0.0)] if g.internal else [(outline, [2.0], 5.0, 0.0)]
    )
    solid = step_gears.stacked_shape(pieces)
    assert BRepCheck_Analyzer(solid).IsValid()
    edges = IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher()
    step._static(TopExp, "MapShapes")(solid, TopAbs_EDGE, edges)
    circles, splines = {}, 0
    for i in range(1, edges.Extent() + 1):
        c = BRepAdaptor_Curve(step._static(TopoDS, "Edge")(edges.FindKey(i)))
        if c.GetType() == GeomAbs_Circle:
            span = abs(c.LastParameter() - c.FirstParameter())
            circles.setdefault(round(c.Circle().Radius(), 6), []).append(span)
        elif c.GetType() == GeomAbs_BSplineCurve:
            splines += 1
    # top and bottom outlines: z tip arcs, z root arcs and 4 z B-splines each
    assert len(circles[round(r_a, 6)]) == 2 * z
    assert len(circles[round(g.root_radius, 6)]) == 2 * z
    assert splines == 2 * 4 * z
    assert np.array(circles[round(r_a, 6)]) == pytest.approx(tip_span, abs=1e-9)


_FREECAD_SCRIPT = """
import json, os, sys
import Part
shape = Part.read(sys.argv[-2])
solids = [[s.Volume, list(s.CenterOfMass), s.isValid()] for s in shape.Solids]
json.dump(solids, open(sys.argv[-1], "w"))
sys.stdout.flush()
os._exit(0)
"""


@pytest.mark.slow
@pytest.mark.skipif(not shutil.which("freecadcmd"), reason="needs FreeCAD (freecadcmd)")
def test_freecad_reads_the_whole_drive_assembly_as_placed(tmp_path):
    """FreeCAD's reader finds every instance of the compound assembly (one
    product per part, placed by instances) as a valid solid with Open
    CASCADE's volume and centre of mass, as read here instance by instance."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    scene = tmp_path / "s.toml"
    scene.write_text(
        "[first_stage]\npinion_teeth = 18\nwheel_teeth = 36\ncrank_gear_teeth = 90\n"
        "module = 1.5\nshift_pinion = 0.5\nshift_crank_gear = 0.5\nface_width = 15.0\n"
        '[export]\nformats = ["step"]\nassembly_angles_deg = [25.0]\n'
    )
    out = tmp_path / "o"
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(out), "--quiet"],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    asm = out / "assembly_025deg.step"
    (tmp_path / "fc.py").write_text(_FREECAD_SCRIPT)
    # FreeCAD's own Python, without this interpreter's environment
    env = {
        "PATH": os.environ.get("PATH", "/usr/bin:/bin"),
        "HOME": str(tmp_path),
        "LANG": "C.UTF-8",
    }
    subprocess.run(
        ["freecadcmd", str(tmp_path / "fc.py"), str(asm), str(tmp_path / "fc.json")],
        env=env,
        capture_output=True,
        timeout=600,
    )
    theirs = json.loads((tmp_path / "fc.json").read_text())
    _, parts = step.read_step(asm)
    assert len(theirs) == len(parts) == 70 and all(valid for _, _, valid in theirs)
    left = list(range(len(theirs)))
    for p in parts:
        g = GProp_GProps()
        step._static(BRepGProp, "VolumeProperties")(p.shape, g)
        c = g.CentreOfMass()
        com = np.array([c.X(), c.Y(), c.Z()])
        k = min(left, key=lambda i: np.linalg.norm(np.array(theirs[i][1]) - com))
        left.remove(k)
        assert theirs[k][0] == pytest.approx(g.Mass(), rel=1e-9), p.name
        assert np.array(theirs[k][1]) == pytest.approx(com, abs=1e-6), p.name


@pytest.mark.slow
def test_assembly_product_unlike_its_part_file_fails_the_read_back(tmp_path, monkeypatch, capsys):
    """The read-back compares each assembly product with its own part file (their
    quick boxes, equal for equal geometry): a product 1 um off its part file stops
    the run."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform
    from OCP.gp import gp_Trsf, gp_Vec

    from corr_cad.run import cli

    real = step.write_assembly_step

    def swapped(shapes, *args, **kw):  # the roller's geometry 1 um off its part file's
        t = gp_Trsf()
        t.SetTranslation(gp_Vec(0.0, 0.0, 0.001))
        moved = BRepBuilderAPI_Transform(shapes["roller"], t, True).Shape()
        return real({**shapes, "roller": moved}, *args, **kw)

    monkeypatch.setattr(step, "write_assembly_step", swapped)
    scene = tmp_path / "s.toml"
    scene.write_text('[export]\nformats = ["step"]\n')
    code = cli.main(
        ["run", str(scene), "--out", str(tmp_path / "o"), "--executor", "serial", "--quiet"]
    )
    assert code != 0
    assert "product roller is not roller.step" in capsys.readouterr().err
