"""The parts the drive floats its cams on, drawn: needles, eccentric journals, seats.

Under ``model = "drive"`` with ``[bearings.eccentric]`` the cam's bore is the
needle bearing's outer race (concentric with the disc), the needles sit on the
pitch circle ``R_b - D / 2`` and the crankshaft's eccentric journals
(``R_b - D - Pd / 2``) are ``e`` off its axis, 180 deg apart. The reference values
here come from those closed forms, not from the exporter.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest

from corr_cad.geometry.bearing_parts import (
    bearing_placements,
    cage_angle,
    core_radius,
    needle_rows,
    needle_spin,
    seat_radius,
)
from corr_cad.geometry.design import GearDesign
from corr_cad.mechanics.crank.bearing import EccentricBearing

BEARING = EccentricBearing(
    needles=40, needle_diameter=6.0, needle_length=12.0, diametral_clearance=0.005
)

#: The prototype's second stage on the drive model, both cams on 40 x 6 x 12 needles.
SCENE = """[design]
tooth_count = 25
cam_radius = 135.0
roller_radius = 8.0
roller_length = 12.0
eccentricity = 3.5
[export]
formats = ["dxf", "stl", "3mf", "glb", "ply", "step", "interference"]
tolerance = 0.001
interference_method = "mesh"
interference_positions = 2
[solver]
positions = 40
model = "drive"
[bearings.eccentric]
needles = 40
needle_diameter = 6.0
needle_length = 12.0
diametral_clearance = 0.005
"""


def test_the_bearing_s_sizes_by_hand():
    """Prototype (R_b = 47.2, e = 3.5): pitch radius 44.2, journal 41.1975, core 37, seat 33."""
    d = GearDesign()
    a, b = needle_rows(d, BEARING)
    assert d.cam_bore_radius == 47.2
    assert a.pitch_radius == pytest.approx(47.2 - 3.0, abs=1e-12)
    assert a.journal_radius == pytest.approx(47.2 - 6.0 - 0.0025, abs=1e-12)
    assert (a.z_low, b.z_low) == (0.0, 12.0 + 8.0)  # centred in rows [0, 12] and [20, 32]
    assert core_radius(d, [a, b]) == 37.0  # floor to 0.5 of 41.1975 - 3.5 - 0.25
    assert seat_radius(d, [a, b]) == 33.0  # floor to 0.5 of 0.9 * 37


def test_the_shaft_drawn_without_the_crank_sections_is_the_derived_one():
    """The drive with bearings and neither [crankshaft] nor [bearings.crank]: the shaft drawn is
    default_layout's, by hand on the prototype (d_e = 94.4 - 12 = 82.4, d = floor(0.8 (82.4 - 7))
    = 60, rollers round(12) = 12 mm, B = round(21.6) = 22, supports -2 t - B / 2 = -27 and
    2 w + 3 t + B / 2 = 59, gear -27 - 22 = -49, outside diameter 1.45 d + 2 D = 111)."""
    import tomllib

    from corr_cad.run.scene.scene import parse_scene
    from corr_cad.run.stages.stages_bearing_parts import needle_rows_of

    scene = parse_scene(tomllib.loads(SCENE))
    assert scene.crank is None
    c = needle_rows_of(scene).crank
    assert (c.shaft_diameter, c.eccentric_diameter, c.eccentric_length) == (60.0, 82.4, 12.0)
    assert c.eccentric_positions == (6.0, 26.0) and c.support_positions == (-27.0, 59.0)
    assert (c.support_width, c.gear_position, c.bore_diameter) == (22.0, -49.0, 0.0)
    assert c.support_outer_diameter == pytest.approx(111.0, abs=1e-12)


def test_cage_and_needle_speeds_against_rolling_on_both_races():
    """Each needle rolls without slip on both races: the contact speeds match."""
    d = GearDesign()
    row = needle_rows(d, BEARING)[0]
    wi, wo = 1.0, 1.0 / 26.0
    wc, wn = cage_angle(row, wi, wo), needle_spin(row, wi, wo)
    rn = 0.5 * row.needle_diameter
    ri, ro = row.pitch_radius - rn, row.pitch_radius + rn
    # in the cage's frame: races at (w - wc) r, needle surface at -/+ (wn - wc) rn
    assert (wi - wc) * ri == pytest.approx(-(wn - wc) * rn, rel=1e-12)
    assert (wo - wc) * ro == pytest.approx((wn - wc) * rn, rel=1e-12)
    # a stationary outer race: the classic cage speed (1 - gamma) / 2
    assert cage_angle(row, 1.0, 0.0) == pytest.approx(0.5 * (1 - 6.0 / 88.4), rel=1e-12)


def test_bad_bearings_are_refused_in_one_line():
    from corr_cad.errors import DesignError

    d = GearDesign()
    with pytest.raises(DesignError, match=r"needle_length = 13: .* allowed range \(0, 12\]"):
        needle_rows(d, EccentricBearing(40, 6.0, 13.0))
    with pytest.raises(DesignError, match="needles = 47: .*allowed range 3..46"):
        needle_rows(d, EccentricBearing(47, 6.0, 12.0))


def _bearing_solids(d: GearDesign, rows, tol: float):
    from corr_cad.export import mesh
    from corr_cad.geometry.bearing_parts import crankshaft_pieces, needle_pieces
    from corr_cad.geometry.first_stage_parts import piece_outlines
    from corr_cad.geometry.parts import part_outlines
    from corr_cad.geometry.profile import undercut_analysis, working_profile

    working = working_profile(d, undercut_analysis(d))
    solids = {n: mesh.solid(o) for n, o in part_outlines(d, working, tol, floating=True).items()}
    pieces = piece_outlines(
        {"needle": needle_pieces(rows[0]), "crankshaft": crankshaft_pieces(d, rows, 12.0)}, tol
    )
    extra = {k: mesh.stacked_solid(p) for k, p in pieces.items()}
    return solids, extra


@pytest.mark.parametrize("clearance", [0.0, 0.005])
def test_the_needles_do_not_interfere_with_the_cam_or_the_eccentric(clearance):
    """Every needle against its cam, the other cam, the crankshaft and every other needle,
    at 4 crank angles: no overlap beyond the tessellation's lens at a designed contact;
    a needle drawn 0.02 mm too thick is found."""
    from dataclasses import replace

    from corr_cad.export import mesh
    from corr_cad.run.stages.stages_bearing_parts import contact_allowances

    d = GearDesign()
    tol = 0.002
    rows = needle_rows(d, replace(BEARING, diametral_clearance=clearance))
    solids, extra = _bearing_solids(d, rows, tol)
    contacts = contact_allowances(d, rows, tol)
    for angle in (0.0, 33.0, 101.5, 250.0):
        asm = mesh.assembly(d, solids, math.radians(angle), floating=True)
        placed = {k: v for k, v in asm.parts.items() if k.startswith("cam_")}
        for p in bearing_placements(d, rows, math.radians(angle)):
            placed[p.name] = mesh.place(extra[p.part], p)
        checked, overlaps = mesh.solid_overlaps(placed, contacts=contacts)
        n = len(placed)
        assert checked == n * (n - 1) // 2 and not overlaps, (angle, overlaps[:3])
    # the mistake the check must see: needles 0.02 mm thicker than the gap
    fat = needle_rows(d, replace(BEARING, needle_diameter=6.0))[0]
    from corr_cad.geometry.first_stage_parts import piece_outlines

    thick = piece_outlines({"n": [(3.01, [], 12.0, 0.0)]}, tol)["n"]
    big = mesh.stacked_solid(thick)
    asm = mesh.assembly(d, solids, 0.0, floating=True)
    p = bearing_placements(d, [fat, fat], 0.0)[1]
    _, overlaps = mesh.solid_overlaps(
        {"cam_a": asm.parts["cam_a"], p.name: mesh.place(big, p)}, contacts=contacts
    )
    assert overlaps and overlaps[0]["volume_mm3"] > contacts[("needle_a_", "cam_a")]


def test_the_input_inertia_with_floating_cams_against_a_hand_sum():
    """compound.toml's parts with the cams on 40 x 6 x 12 needles: the cams (annuli) and the
    needles (cylinders) summed here from closed forms; the other parts as the files give."""
    import tomllib
    from pathlib import Path

    from corr_cad.geometry.first_stage import FirstStageGeometry  # noqa: F401
    from corr_cad.geometry.first_stage_parts import first_stage_profiles
    from corr_cad.geometry.gear_outline import approximate_gear
    from corr_cad.geometry.parts import part_outlines
    from corr_cad.geometry.profile import undercut_analysis, working_profile
    from corr_cad.mechanics.gears.first_stage_loads import STEEL_DENSITY, drive_mass_inertia
    from corr_cad.run.scene.scene import load_scene, parse_scene
    from corr_cad.run.stages.stages_bearing_parts import needle_rows_of

    scene = load_scene(Path(__file__).resolve().parents[1] / "templates" / "compound.toml")
    d, fs = scene.design, scene.first_stage
    # the parts the CLI draws: the needles and the crankshaft (derived from the design)
    drive = parse_scene(tomllib.loads(_compound_with_crank("")))
    rows = needle_rows_of(drive)
    assert rows.crank.shaft_diameter == 60.0 and list(rows) == needle_rows(d, BEARING)
    verts = {
        k: approximate_gear(getattr(fs, k), 1e-3).vertices
        for k in ("pinion", "wheel", "crank_gear")
    }
    outlines = part_outlines(d, working_profile(d, undercut_analysis(d)), 1e-3, floating=True)
    got = drive_mass_inertia(d, fs, first_stage_profiles(d, fs, verts, rows), outlines, rows)
    i1, z, e, w = fs.ratio, d.tooth_count, d.eccentricity, d.face_width
    rho = STEEL_DENSITY
    # the cam: an annulus R = 135, R_b = 47.2, spinning about its centre as the rollers
    # roll it (the frame their cage, the ring fixed): 2 L / R_j = 2 * 143 / 135 times the
    # output, the output 1/(z + 1) of the crank; the same spin as the lives'
    R, Rb = d.cam_radius, d.cam_bore_radius
    assert (R, d.roller_radius) == (135.0, 8.0)
    wo = 2 * (135.0 + 8.0) / 135.0 / (z + 1)
    m_cam = rho * math.pi * (R**2 - Rb**2) * w
    i_cam = 0.5 * m_cam * (R**2 + Rb**2)
    cams = 2 * (i_cam * (wo / i1) ** 2 + m_cam * e**2 / i1**2)
    # a needle: orbit e with the crank, pitch radius at the cage speed, spin rolling
    dn, ln, rp = 6.0, 12.0, 44.2
    m_n = rho * math.pi * (dn / 2) ** 2 * ln
    g = dn / (2 * rp)
    wc = 0.5 * ((1 - g) + wo * (1 + g))
    wn = wc + rp / dn * (1 - g * g) * (wo - 1.0)
    needles = 80 * (m_n * (e**2 + (rp * wc) ** 2) + m_n * dn**2 / 8 * wn**2) / i1**2
    others = sum(
        p["count"] * p["inertia_kg_m2"] * p["reflected_by"]
        for k, p in got["parts"].items()
        if k not in ("disk_cam", "needle")
    )
    hand = others + (cams + needles) * 1e-6
    # the files' cam is its outline, polygons inscribed within 1e-3 mm: I_c to ~2e-5,
    # and the floating cams are 8 % of the figure (the old 1/(z + 1) spin: 7 % off)
    assert got["input_inertia_kg_m2"] == pytest.approx(hand, rel=5e-6)
    # the cams turning with the crank instead (I + m e^2 about the axis): the upper bound
    fixed = others + (2 * (i_cam + m_cam * e**2) / i1**2 + needles) * 1e-6
    # (the files' cam is its outline, polygons inscribed within 1e-3 mm: I_c to ~2e-5)
    assert got["input_inertia_cams_fixed_kg_m2"] == pytest.approx(fixed, rel=1e-4)
    assert got["input_inertia_cams_fixed_kg_m2"] > 5 * got["input_inertia_kg_m2"]
    assert "Harris" in got["inertia_convention"]
    # docs/physics.md: 5.35e-4 kg m^2 floating against 4.38e-3 fixed; the cams themselves
    # 128 times less than fixed
    assert got["input_inertia_kg_m2"] == pytest.approx(5.35e-4, rel=2e-3)
    assert got["parts"]["disk_cam"]["spin_per_crank"] == pytest.approx(wo, rel=1e-12)
    from corr_cad.mechanics.life import rolling_speeds

    assert rolling_speeds(d, "bearing")["bearing"] == pytest.approx((1 - wo) * (z + 1), rel=1e-12)
    assert got["input_inertia_cams_fixed_kg_m2"] == pytest.approx(4.38e-3, rel=2e-3)


@pytest.mark.slow
def test_the_console_and_datasheet_say_the_cams_float(tmp_path):
    """compound.toml on the drive with bearings: the inertia's convention in datasheet.json,
    the console's whole-drive line names it and gives the cams-fixed figure."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "templates" / "compound.toml").read_text()
    text = text.split("[export]")[0] + '[export]\nformats = ["datasheet"]\n'
    text += '[solver]\nmodel = "drive"\n' + SCENE.split("[solver]")[1].split("\n", 3)[3]
    (tmp_path / "s.toml").write_text(text)
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr[-3000:]
    ds = json.loads((tmp_path / "out" / "datasheet.json").read_text())
    assert "rolling kinematics" in ds["inertia_convention"]
    assert ds["input_inertia_cams_fixed_kg_m2"] > 5 * ds["input_inertia_kg_m2"]
    assert "cams floating on their needle bearings" in r.stdout + r.stderr
    html = (tmp_path / "out" / "datasheet.html").read_text(encoding="utf-8")
    assert "the cams float on their needle bearings" in html


def test_a_bearing_that_cannot_be_drawn_is_refused_in_one_line(tmp_path):
    """Needles longer than the cam is wide: exit 2, one line naming the key, nothing written."""
    (tmp_path / "s.toml").write_text(
        SCENE.replace(
            'formats = ["dxf", "stl", "3mf", "glb", "ply", "step", "interference"]',
            'formats = ["dxf"]',
        ).replace("needle_length = 12.0", "needle_length = 13.0")
    )
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2, r.stderr
    errors = [x for x in r.stderr.splitlines() if "error" in x]
    assert len(errors) == 1 and "Traceback" not in r.stderr
    assert "needle_length = 13: " in errors[0] and "e.g. 12" in errors[0]
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def _circles(path):
    """(radius, x, y, z) of every circle edge in a STEP file, as OCP reads it."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.GeomAbs import GeomAbs_Circle
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    from corr_cad.export import step

    shape = step._read_one_shape(path, heal=False)
    out = []
    ex = TopExp_Explorer(shape, TopAbs_EDGE)
    while ex.More():
        c = BRepAdaptor_Curve(step._static(TopoDS, "Edge")(ex.Current()))
        if c.GetType() == GeomAbs_Circle:
            circ = c.Circle()
            p = circ.Location()
            out.append((circ.Radius(), p.X(), p.Y(), p.Z()))
        ex.Next()
    return out


@pytest.mark.slow
def test_a_drive_with_bearings_writes_its_parts_in_every_format(tmp_path):
    """The CLI writes needle.* and crankshaft.* in DXF, meshes and STEP, places them in
    both assemblies under the same names, and the STEP journals are e off the axis."""
    pytest.importorskip("OCP")
    import ezdxf
    import trimesh

    (tmp_path / "s.toml").write_text(SCENE)
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr[-3000:]
    out = tmp_path / "out"
    for part in ("needle", "crankshaft"):
        for fmt in ("dxf", "stl", "3mf", "glb", "ply", "step"):
            assert (out / f"{part}.{fmt}").stat().st_size > 0, (part, fmt)
    e, rj = 3.5, 47.2 - 6.0 - 0.0025
    # STEP: the eccentric journals' circles at (0, +e) and (0, -e), to 1e-9 mm
    journals = [c for c in _circles(out / "crankshaft.step") if abs(c[0] - rj) < 1e-9]
    centres = sorted({(round(x, 6), round(y, 6)) for _, x, y, _ in journals})
    assert len(centres) == 2, journals
    for _, x, y, _ in journals:
        assert abs(x) < 1e-9 and abs(abs(y) - e) < 1e-9
    ys = {math.copysign(1, y) for _, _, y, _ in journals}
    assert ys == {1.0, -1.0}  # 180 deg apart
    # the cam's bore concentric with its disc, in STEP and DXF
    bores = [c for c in _circles(out / "disk_cam.step") if abs(c[0] - 47.2) < 1e-9]
    assert bores and all(abs(x) < 1e-12 and abs(y) < 1e-12 for _, x, y, _ in bores)
    dxf_bore = [
        c
        for c in ezdxf.readfile(out / "disk_cam.dxf").modelspace().query("CIRCLE")
        if abs(c.dxf.radius - 47.2) < 1e-12
    ]
    assert tuple(dxf_bore[0].dxf.center)[:2] == (0.0, 0.0)
    dxf_journals = [
        c
        for c in ezdxf.readfile(out / "crankshaft.dxf").modelspace().query("CIRCLE")
        if abs(c.dxf.radius - rj) < 1e-12
    ]
    assert sorted(c.dxf.center[1] for c in dxf_journals) == [-e, e]
    # the assemblies: the same instance names in STEP and the meshes
    from corr_cad.export import step

    _, parts = step.read_step(out / "assembly_000deg.step", heal=False)
    names = [p.name for p in parts]
    want = {f"needle_{row}_{j:02d}" for row in "ab" for j in range(1, 41)} | {"crankshaft"}
    assert want <= set(names)
    assert {p.product for p in parts if p.name.startswith("needle_")} == {"needle"}
    threemf = trimesh.load(out / "assembly_000deg.3mf")
    assert sorted(threemf.geometry) == sorted(names)
    # a needle where the placement says: the pitch radius from its eccentric's centre
    n1 = threemf.geometry["needle_a_01"]
    centre = 0.5 * (n1.bounds[0] + n1.bounds[1])
    assert math.hypot(centre[0] - 0.0, centre[1] - e) == pytest.approx(44.2, abs=2e-3)
    manifest = json.loads((out / "manifest.json").read_text())
    inter = manifest["interference"]
    assert inter["ok"] and inter["other_pairs"]["overlaps"] == 0
    assert "needle_a_*/cam_a" in inter["other_pairs"]["needle_contact_allowance_mm3"]
    np.testing.assert_equal(
        sorted(manifest["step"]["assembly_000deg.step"]["instance_counts"]),
        sorted(["inner_gear", "disk_cam", "roller", "teeth_frame", "needle", "crankshaft"]),
    )


def test_scenes_without_bearings_draw_no_bearing_parts():
    from corr_cad.run.stages.stages_bearing_parts import needle_rows_of

    paper = SimpleNamespace(solver=SimpleNamespace(drive=False), bearing=BEARING)
    assert needle_rows_of(paper) is None
    rigid = SimpleNamespace(solver=SimpleNamespace(drive=True), bearing=None)
    assert needle_rows_of(rigid) is None


def test_the_assembly_turns_a_floating_cam_by_the_lives_spin():
    """cam_a's angle in the assembly is the output's turn times 2 L / R_j, the rolling
    kinematics' spin that the lives use; each needle set's cage rolls on that cam."""
    from corr_cad.geometry.placement import assembly_placements
    from corr_cad.mechanics.life import rolling_speeds

    d = GearDesign(tooth_count=25, cam_radius=135.0, roller_radius=8.0, eccentricity=3.5)
    crank = 0.7  # relative to the frame: the output turns crank / z, the crank crank + crank/z
    cams = {p.name: p for p in assembly_placements(d, crank, floating=True)}
    spin = 2 * 143.0 / 135.0
    assert cams["cam_a"].angle_rad == pytest.approx(crank / 25 * spin, rel=1e-12)
    assert cams["cam_b"].angle_rad == cams["cam_a"].angle_rad
    # the lives' bearing speed per output turn: the crank's z + 1 less the cam's
    assert rolling_speeds(d, "bearing")["bearing"] == pytest.approx(26 - spin, rel=1e-12)
    row = needle_rows(d, BEARING)[0]
    n1 = bearing_placements(d, [row, row], crank)[1]
    phi = crank * 26 / 25
    g = 6.0 / 88.4
    cage = 0.5 * (phi * (1 - g) + crank / 25 * spin * (1 + g))
    x, y = 3.5 * np.array([math.sin(phi), math.cos(phi)]) + 44.2 * np.array(
        [math.sin(cage), math.cos(cage)]
    )
    assert n1.offset[:2] == pytest.approx((x, y), abs=1e-9)


@pytest.mark.slow
def test_the_crankshaft_drawn_is_the_crank_model_s(tmp_path):
    """[crankshaft] shaft_diameter = 50 on the prototype: crankshaft.step's core reads back
    50 mm, its journals sit at the crank model's eccentric_positions (w / 2 and
    w + t + w / 2, 12 mm long) and its support seats at its support_positions with
    its bearing's width (the defaults: B = round(1.8 round(0.2 d)) = 18 mm at
    -2 t - B / 2 = -25 and 2 w + 3 t + B / 2 = 57); the assembly does not interfere."""
    pytest.importorskip("OCP")
    import trimesh

    (tmp_path / "s.toml").write_text(
        SCENE.replace(
            '"step", "interference"]', '"step", "interference"]\nassembly_angles_deg = [0.0]'
        )
        + "[crankshaft]\nshaft_diameter = 50\n"
    )
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr[-3000:]
    out = tmp_path / "out"
    circles = _circles(out / "crankshaft.step")
    core = {round(z, 9) for rad, x, y, z in circles if abs(rad - 25.0) < 1e-9 and x == y == 0}
    assert core and all(abs(x) < 1e-9 and abs(y) < 1e-9 for rad, x, y, _ in circles if rad == 25)
    rj = 0.5 * (2 * 47.2 - 2 * 6.0 - 0.005)  # the model's journal less the clearance
    journals = sorted(
        (round(z, 9), round(y, 9)) for rad, x, y, z in circles if abs(rad - rj) < 1e-9
    )
    w, t, e = 12.0, 8.0, 3.5
    ja, jb = 0.5 * w, 1.5 * w + t
    assert sorted(set(journals)) == [(ja - 6, e), (ja + 6, e), (jb - 6, -e), (jb + 6, -e)]
    B = 18.0
    s1, s2 = -2 * t - B / 2, 2 * w + 3 * t + B / 2
    assert {s1 - B / 2, s1 + B / 2, s2 - B / 2, s2 + B / 2} <= core
    lo, hi = trimesh.load(out / "crankshaft.stl").bounds[:, 2]
    assert (lo, hi) == pytest.approx((s1 - B / 2, s2 + B / 2), abs=1e-9)
    inter = json.loads((out / "manifest.json").read_text())["interference"]
    assert inter["ok"] and inter["other_pairs"]["overlaps"] == 0


def _compound_with_crank(crank: str) -> str:
    """templates/compound.toml on the drive with 40 x 6 x 12 needles and ``crank``."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "templates" / "compound.toml").read_text()
    export = SCENE.split("[export]")[1].split("[solver]")[0]
    export += "assembly_angles_deg = [0.0]\n"
    return (
        text.split("[export]")[0]
        + "[export]"
        + export
        + "[solver]"
        + SCENE.split("[solver]")[1]
        + crank
    )


@pytest.mark.slow
def test_the_compound_s_crankshaft_is_the_crank_model_s(tmp_path):
    """compound.toml on the drive, [crankshaft] shaft_diameter = 50 (its other sizes and
    the support bearings derived): crankshaft.step is the crank model's shaft, not a shaft of
    the first stage's own layout. Its journals are e off the axis (to 1e-9 mm), centred at the
    model's eccentric_positions; its seats at its support_positions with the bearing's
    width; its flange's face toward the eccentrics at its gear_position (one bearing width
    beyond the first support: -25 - 18 = -43), the crank gear hanging below the flange; the
    crank bearings where the model puts them; the mass from these parts; nothing interferes."""
    pytest.importorskip("OCP")
    import trimesh

    (tmp_path / "s.toml").write_text(_compound_with_crank("[crankshaft]\nshaft_diameter = 50\n"))
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr[-3000:]
    out = tmp_path / "out"
    w, t, e = 12.0, 8.0, 3.5
    B = 18.0  # round(1.8 round(0.2 d)), d = 50
    s1, s2 = -2 * t - B / 2, 2 * w + 3 * t + B / 2  # -25, 57
    zg, f = s1 - B, 5.0  # the gear's place; the flange max(5, 2 m) thick
    b, g = 15.0, 1.0  # the first stage's face width, the axial gap
    rj = 0.5 * (2 * 47.2 - 2 * 6.0 - 0.005)
    ja, jb = 0.5 * w, 1.5 * w + t
    # the part's own coordinates start at the flange's bottom face (zg - f)
    circles = [(rad, x, y, z + zg - f) for rad, x, y, z in _circles(out / "crankshaft.step")]
    journals = [c for c in circles if abs(c[0] - rj) < 1e-9]
    for _, x, y, _ in journals:
        assert abs(x) < 1e-9 and abs(abs(y) - e) < 1e-9
    got = sorted({(round(z, 9), math.copysign(1.0, y)) for _, _, y, z in journals})
    assert got == [(ja - 6, 1.0), (ja + 6, 1.0), (jb - 6, -1.0), (jb + 6, -1.0)]
    core = {round(z, 9) for rad, x, y, z in circles if abs(rad - 25.0) < 1e-9}
    # (the lower seat runs on into the shaft down to the flange: one cylinder, no edge at s1 - B/2)
    assert {zg, s1 + B / 2, s2 - B / 2, s2 + B / 2} <= core
    assert all(abs(x) < 1e-9 and abs(y) < 1e-9 for rad, x, y, _ in circles if rad == 25.0)
    # the assembly: the shaft, its flange and the gear where the crank model has them
    asm = trimesh.load(out / "assembly_000deg.3mf")
    lo, hi = asm.geometry["crankshaft"].bounds[:, 2]
    assert (lo, hi) == pytest.approx((zg - f, s2 + B / 2), abs=1e-9)
    gear = asm.geometry["crank_gear"].bounds[:, 2]
    assert gear == pytest.approx((zg - f - g - b, zg - f), abs=1e-9)
    for k, s in ((1, s1), (2, s2)):
        zb = asm.geometry[f"crank_bearing_{k}"].bounds[:, 2]
        assert zb == pytest.approx((s - B / 2, s + B / 2), abs=1e-9)
    # the crankshaft's mass: its flange (the crank gear's rim) and the model's cylinders
    manifest = json.loads((out / "manifest.json").read_text())
    drive = manifest["drive"]["parts"]
    rim = drive["crank_gear"]  # noqa: F841  (its own part; the flange is the shaft's)
    from corr_cad.geometry.first_stage_parts import first_stage_layout
    from corr_cad.mechanics.gears.first_stage_loads import STEEL_DENSITY
    from corr_cad.run.scene.scene import load_scene

    scene = load_scene(tmp_path / "s.toml")
    lay = first_stage_layout(scene.design, scene.first_stage)
    R = lay.rim_outer
    shaft_len = (s2 + B / 2) - zg - 2 * w
    vol = math.pi * (R * R * f + 25.0**2 * shaft_len + 2 * rj * rj * w)
    assert drive["crankshaft"]["mass_kg"] == pytest.approx(STEEL_DENSITY * vol, rel=1e-12)
    i_hand = (
        STEEL_DENSITY
        * math.pi
        * (0.5 * R**4 * f + 0.5 * 25.0**4 * shaft_len + 2 * w * rj * rj * (0.5 * rj * rj + e * e))
    )
    assert drive["crankshaft"]["inertia_kg_m2"] == pytest.approx(i_hand * 1e-6, rel=1e-12)
    # the support bearings' placeholders: from the shaft to 2 rollers beyond the pitch circle
    Dr, dm = 10.0, 1.45 * 50.0
    ro = 0.5 * dm + Dr
    m_brg = STEEL_DENSITY * math.pi * (ro * ro - 25.0**2) * B
    assert drive["crank_bearing"]["mass_kg"] == pytest.approx(m_brg, rel=1e-12)
    inter = manifest["interference"]
    assert inter["ok"] and inter["other_pairs"]["overlaps"] == 0
    # the DXF: the journals' circles at (0, +-e)
    import ezdxf

    dxf_journals = [
        c
        for c in ezdxf.readfile(out / "crankshaft.dxf").modelspace().query("CIRCLE")
        if abs(c.dxf.radius - rj) < 1e-12
    ]
    assert sorted(c.dxf.center[1] for c in dxf_journals) == [-e, e]


def test_a_crank_gear_inside_the_supports_is_refused_with_the_first_stage(tmp_path):
    """[first_stage] hangs the crank gear on a flange below the lower support bearing: a
    gear_position above that bearing's outer face is one line naming the key and the range,
    exit 2, nothing written."""
    text = _compound_with_crank("[crankshaft]\nshaft_diameter = 50\ngear_position = -20.0\n")
    lines = text.splitlines()
    text = "\n".join('formats = ["dxf"]' if x.startswith("formats") else x for x in lines)
    (tmp_path / "s.toml").write_text(text + "\n")
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2, r.stderr[-2000:]
    errors = [x for x in r.stderr.splitlines() if "error" in x]
    assert len(errors) == 1 and "Traceback" not in r.stderr, r.stderr
    assert "[crankshaft] gear_position = -20.0: " in errors[0]
    assert "(-inf, -34] mm, e.g. -43" in errors[0]
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())
