"""STEP AP214 export: real B-rep read back by Open CASCADE."""

import builtins

import numpy as np
import pytest
import trimesh

from corr_cad import ExportError, GearDesign, approximate, working_profile
from corr_cad.parts import part_outlines
from corr_cad.sampling import distance_to_curve

step = pytest.importorskip("corr_cad.export.step")
pytest.importorskip("OCP")

TOL = 1e-3


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    design = GearDesign()
    w = working_profile(design)
    spline = approximate(w, "spline", TOL)
    shapes = step.part_shapes(design, spline)
    out = tmp_path_factory.mktemp("step")
    paths = {k: step.write_step(v, out / f"{k}.step", k) for k, v in shapes.items()}
    return design, w, part_outlines(design, w, TOL), paths


@pytest.mark.parametrize("part", ["ring", "cam", "roller", "frame"])
def test_step_reads_back_with_volume_and_bbox(written, part):
    design, w, outlines, paths = written
    text = paths[part].read_text(errors="replace")
    assert "AUTOMOTIVE_DESIGN" in text  # AP214
    assert "B_SPLINE_CURVE" in text or part != "ring"
    deflection = 0.1
    verts, faces, bbox = step.read_step_mesh(paths[part], deflection)
    tm = trimesh.Trimesh(verts, faces, process=False)
    tm.merge_vertices()
    assert tm.is_watertight
    o = outlines[part]
    assert abs(tm.volume - o.exact_volume) <= (deflection + TOL) * o.boundary_length * o.thickness
    radius = {
        "ring": design.ring_outer_radius,
        "cam": design.cam_radius,
        "roller": design.roller_radius,
        "frame": design.frame_outer_radius,
    }[part]
    np.testing.assert_allclose(bbox[1, :2], [radius, radius], atol=1e-6)
    assert bbox[1, 2] - bbox[0, 2] == pytest.approx(o.thickness, abs=1e-6)


def test_profile_curve_in_step_is_within_tolerance(written):
    design, w, _, paths = written
    curves = step.read_step_curves(paths["ring"], samples_per_edge=20000)
    assert curves
    for c in curves:
        d, _ = distance_to_curve(w, c[:, :2])
        assert d.max() <= TOL


def test_missing_extra_gives_install_hint(monkeypatch):
    real_import = builtins.__import__

    def no_ocp(name, *a, **k):
        if name == "OCP" or name.startswith("OCP."):
            raise ImportError("No module named 'OCP'")
        return real_import(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", no_ocp)
    with pytest.raises(ExportError, match=r"pip install -e '\.\[step\]'"):
        step.require_ocp()
