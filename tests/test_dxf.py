"""DXF round trips through ezdxf.readfile for every representation."""

import math

import ezdxf
import numpy as np
import pytest

from corr_cad import GearDesign, approximate, theoretical_profile, working_profile
from corr_cad.export import dxf
from corr_cad.geometry.sampling import distance_to_curve

from .test_dxf_accuracy import read_layer


def _perimeter(points):
    return float(np.sum(np.linalg.norm(np.roll(points, -1, 0) - points, axis=1)))


@pytest.fixture(scope="module", params=["polyline", "arcs", "spline"])
def written(request, tmp_path_factory):
    design = GearDesign()
    tol = 1e-3
    w, t = working_profile(design), theoretical_profile(design)
    aw = approximate(w, request.param, tol)
    at = approximate(t, request.param, tol)
    out = tmp_path_factory.mktemp(request.param)
    paths = dxf.write_all(design, aw, at, out)
    return design, request.param, tol, w, t, aw, at, paths


def test_files_read_back_with_units_and_header(written):
    design, rep, tol, *_, paths = written
    assert set(paths) == {"inner_gear", "disk_cam", "roller", "teeth_frame"}
    for part, path in paths.items():
        doc = ezdxf.readfile(path)  # a full parse, not only audit
        assert doc.dxfversion == "AC1032"  # R2018
        assert doc.header["$INSUNITS"] == 4
        props = dict(doc.header.custom_vars)
        assert props["corr_cad.part"] == part
        assert float(props["corr_cad.eccentricity"]) == design.eccentricity
        assert int(props["corr_cad.tooth_count"]) == design.tooth_count
        assert len(doc.audit().errors) == 0


@pytest.mark.parametrize("layer", ["WORKING_PROFILE", "THEORETICAL_PROFILE"])
def test_profile_round_trip(written, layer):
    design, rep, tol, w, t, aw, at, paths = written
    curve, approx = (w, aw) if layer == "WORKING_PROFILE" else (t, at)
    # Read back with ezdxf's own path / bulge / B-spline handling.
    kinds = {
        e.dxftype()
        for e in ezdxf.readfile(paths["inner_gear"]).modelspace()
        if e.dxf.layer == layer
    }
    assert kinds == {"SPLINE" if rep == "spline" else "LWPOLYLINE"}
    chains = read_layer(paths["inner_gear"], layer)
    pts = np.vstack([c[:-1] for c in chains])
    d, _ = distance_to_curve(curve, pts)
    assert d.max() <= tol
    # Enclosed area: the difference is bounded by deviation x perimeter.
    bound = (approx.max_deviation + 1e-6) * _perimeter(pts)
    assert abs(dxf.contour_area(pts) - curve.area()) <= bound
    props = dict(ezdxf.readfile(paths["inner_gear"]).header.custom_vars)
    assert float(props["corr_cad.max_deviation_mm"]) == aw.max_deviation


def test_bulge_area_is_exact(written):
    design, rep, tol, w, t, aw, at, paths = written
    if rep == "spline":
        pytest.skip("no bulges in a spline")
    doc = ezdxf.readfile(paths["inner_gear"])
    (pl,) = [e for e in doc.modelspace() if e.dxf.layer == "WORKING_PROFILE"]
    data = np.array(pl.get_points("xyb"))
    exact = dxf.bulge_polygon_area(data[:, :2], data[:, 2])
    from ezdxf import path as ezpath

    flat = np.array([(p.x, p.y) for p in ezpath.make_path(pl).flattening(1e-7, segments=4)])
    dense = dxf.contour_area(flat[:-1])
    assert exact == pytest.approx(dense, abs=1e-3)


def test_nothing_duplicated(written):
    *_, paths = written
    for path in paths.values():
        doc = ezdxf.readfile(path)
        for e in doc.modelspace():
            if e.dxftype() == "LWPOLYLINE":
                v = np.array(e.get_points("xy"))
                steps = np.linalg.norm(np.roll(v, -1, 0) - v, axis=1)
                assert steps.min() > 1e-9  # no repeated vertex, closing one included
                assert e.closed
        circles = [
            (e.dxf.layer, tuple(e.dxf.center), e.dxf.radius)
            for e in doc.modelspace().query("CIRCLE")
        ]
        assert len(circles) == len(set(circles))


def test_ring_cam_roller_geometry(written):
    design, *_, paths = written
    ring = ezdxf.readfile(paths["inner_gear"]).modelspace().query('CIRCLE[layer=="RING_OUTER"]')
    assert [c.dxf.radius for c in ring] == [design.ring_outer_radius]
    cam = ezdxf.readfile(paths["disk_cam"]).modelspace()
    (outer,) = cam.query('CIRCLE[layer=="CAM_OUTER"]')
    (bore,) = cam.query('CIRCLE[layer=="CAM_BORE"]')
    assert outer.dxf.radius == design.cam_radius
    assert math.dist(outer.dxf.center.vec2, bore.dxf.center.vec2) == pytest.approx(
        design.eccentricity
    )
    # Where the bore is: at psi = 0 the roller on +y sits at s = e + L from the crank
    # axis (s = e cos psi + sqrt(L^2 - e^2 sin^2 psi)), L from the cam centre, so the cam
    # centre is e above the axis and the axis (the bore) at (0, -e) in the cam's frame.
    assert tuple(bore.dxf.center.vec2) == pytest.approx((0.0, -design.eccentricity), abs=1e-12)
    (roller,) = ezdxf.readfile(paths["roller"]).modelspace().query("CIRCLE")
    assert roller.dxf.radius == design.roller_radius


def test_frame_slots(written):
    design, *_, paths = written
    msp = ezdxf.readfile(paths["teeth_frame"]).modelspace()
    slots = list(msp.query('LWPOLYLINE[layer=="FRAME_SLOTS"]'))
    assert len(slots) == design.roller_count
    import shapely

    for i, s in enumerate(slots):
        from ezdxf import path as ezpath

        pts = np.array([(p.x, p.y) for p in ezpath.make_path(s).flattening(1e-5, segments=4)])[:-1]
        poly = shapely.Polygon(pts)
        assert poly.is_valid and s.closed
        # Width 2r: the slot is r either side of its radial centre line.
        theta = i * design.slot_pitch_rad
        radial = np.array([math.sin(theta), math.cos(theta)])
        side = pts @ np.array([radial[1], -radial[0]])
        assert side.max() == pytest.approx(design.roller_radius, abs=1e-4)
        assert side.min() == pytest.approx(-design.roller_radius, abs=1e-4)
        # Semicircular ends bulge outwards: the slot contains the roller's whole travel.
        along = pts @ radial
        L, e, r = design.link_length, design.eccentricity, design.roller_radius
        assert along.min() < L - e - r and along.max() > L + e + r
        assert along.min() > design.frame_inner_radius and along.max() < design.frame_outer_radius


def test_unreadable_and_open_contours(tmp_path):
    bad = tmp_path / "bad.dxf"
    bad.write_text("0\nSECTION\n2\nHEADER\n")  # truncated
    with pytest.raises(Exception, match="not a readable DXF"):
        dxf.read_closed_contour(bad, "WORKING_PROFILE")
    doc = ezdxf.new("R2018")
    doc.modelspace().add_lwpolyline([(0, 0), (1, 0), (1, 1)], dxfattribs={"layer": "P"})
    doc.saveas(tmp_path / "open.dxf")
    with pytest.raises(Exception, match="not closed"):
        dxf.read_closed_contour(tmp_path / "open.dxf", "P")


def test_arcs_are_g1_at_every_vertex(written):
    """Wire EDM wants tangent continuity: each arc leaves a vertex along the tangent
    the previous one arrived with (bulge convention: the tangent is the chord turned
    by -theta/2 at the start, +theta/2 at the end, theta = 4 atan(bulge))."""
    design, rep, *_, paths = written
    if rep != "arcs":
        pytest.skip("G1 is promised for arcs")
    doc = ezdxf.readfile(paths["inner_gear"])
    for layer in ("WORKING_PROFILE", "THEORETICAL_PROFILE"):
        (pl,) = doc.modelspace().query(f'LWPOLYLINE[layer=="{layer}"]')
        data = np.array(pl.get_points("xyb"))
        v, b = data[:, :2], data[:, 2]
        chord = np.roll(v, -1, axis=0) - v
        ang = np.arctan2(chord[:, 1], chord[:, 0])
        theta = 4 * np.arctan(b)
        arrive = np.roll(ang + theta / 2, 1)
        leave = ang - theta / 2
        kink = np.angle(np.exp(1j * (leave - arrive)))
        assert np.abs(kink).max() < 1e-8, (layer, np.abs(kink).max())


def test_dxf_economy_at_the_same_accuracy(prototype):
    """Issue 11: arcs <= 700 and polyline <= 2,700 vertices for the prototype at 1 um."""
    w = working_profile(prototype)
    arcs = approximate(w, "arcs", 1e-3)
    poly = approximate(w, "polyline", 1e-3)
    assert arcs.entity_vertex_count <= 700 and arcs.max_deviation <= 1e-3
    assert poly.entity_vertex_count <= 2700 and poly.max_deviation <= 1e-3
