"""Estimates follow what the stages build for a ring with a wavy ``normal_table``.

A table that oscillates along every tooth space is allowed; each wave costs
vertices, control points and triangles. The counts here come from the
approximator run on the modified ring, as the DXF and STEP stages run it.
"""

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.errors import SceneError
from corr_cad.geometry.modification import Modification, NormalTable, modified_profile
from corr_cad.geometry.sampling import approximate
from corr_cad.run.budget.resources import check_scene, estimate
from corr_cad.run.scene.limits import mesh_triangles, modified_ratio, profile_vertices
from corr_cad.run.scene.scene import load_scene


def _wave(rows: int = 200, amplitude: float = 0.002) -> NormalTable:
    psi = np.linspace(0.0, 180.0, rows)
    n = 0.01 + amplitude * np.sin(np.radians(psi) * (rows // 2))
    return NormalTable(tuple(psi.tolist()), tuple(n.tolist()))


WAVY = Modification(normal_table=_wave())


@pytest.mark.parametrize(("rep", "tol"), [("spline", 1e-3), ("spline", 3e-4), ("polyline", 1e-3)])
def test_vertex_estimate_follows_the_approximated_wavy_ring(rep, tol):
    d = GearDesign()
    built = approximate(modified_profile(d, WAVY), rep, tol).entity_vertex_count
    est = profile_vertices(d, rep, tol, WAVY)
    nominal = profile_vertices(d, rep, tol)
    assert (
        built > 3 * approximate(modified_profile(d, Modification()), rep, tol).entity_vertex_count
    )
    # The ratio is measured at 1e-3 mm; a finer tolerance resolves the waves a
    # little more than the nominal ring (0.8 at 3e-4). The nominal estimate was
    # 9 times too low.
    assert 0.75 * built <= est <= 2.5 * built
    assert est > 3 * nominal


def test_a_ring_without_a_table_keeps_the_closed_form():
    d = GearDesign()
    flat = Modification(equidistant_mm=0.01)
    assert modified_ratio(d, None, "spline") == modified_ratio(d, flat, "spline") == 1.0
    assert profile_vertices(d, "spline", 1e-3, flat) == profile_vertices(d, "spline", 1e-3)
    assert mesh_triangles(d, 1e-3, flat) == mesh_triangles(d, 1e-3)
    assert mesh_triangles(d, 1e-3, WAVY)[0] > mesh_triangles(d, 1e-3)[0]


SCENE = (
    '[export]\nformats = ["step", "stl", "3mf", "glb", "ply"]\nchord_tolerance = 0.0003\n'
    "assembly_angles_deg = [0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22]\n[modification]\n"
)


def test_wavy_ring_beyond_the_output_budget_is_refused_up_front(tmp_path):
    psi = np.linspace(0.0, 180.0, 200)
    rows = "".join(
        f"{a:.6f},{b:.6f}\n"
        for a, b in zip(psi, 0.01 + 0.002 * np.sin(np.radians(psi) * 100), strict=True)
    )
    (tmp_path / "wave.csv").write_text("psi_deg,normal_mm\n" + rows)
    (tmp_path / "wavy.toml").write_text(SCENE + 'normal_table = "wave.csv"\n')
    (tmp_path / "flat.toml").write_text(SCENE + "equidistant_mm = 0.01\n")
    flat = check_scene(load_scene(tmp_path / "flat.toml"), 2)  # fits
    assert flat.output_bytes < 1024**3
    wavy = load_scene(tmp_path / "wavy.toml")
    assert estimate(wavy, 2).output_bytes > 1.5 * flat.output_bytes
    with pytest.raises(SceneError, match=r"^\[export\] .*of files.*output budget is 1 GB"):
        check_scene(wavy, 2)


FREE = """[export]
formats = ["modification"]
[load]
input_torque = 1.1e5
[tolerances]
roller_radius = { normal = 0.002 }
[modification.design]
target_backlash_arcmin = 3.0
max_binding_probability = 0.05
family = "free"
equidistant_range_mm = [0.0, 0.03]
steps = 20
samples = 10
positions = 8
"""


def test_free_family_of_twenty_steps_is_estimated_from_its_candidates(tmp_path):
    """160,000 candidates of 2080 cells: 11.5 ms each measured (CPU), 31 min in all;
    the estimate was 5m37s (a microsecond a cell and nothing a candidate)."""
    from corr_cad.run.budget.resources import Budget, time_warning

    (tmp_path / "s.toml").write_text(FREE)
    scene = load_scene(tmp_path / "s.toml")
    est = estimate(scene, 1, "serial")
    measured = 20**4 * 11.5e-3
    assert measured <= est.stages["modification_design"].seconds <= 3 * measured
    assert est.stages["modification_design"].memory >= 20**4 * 2.3e3  # the rows kept
    budget = Budget(3 * 1024**3, 1024**3, 60.0, "default", "default", "default")
    line = time_warning(scene, est, budget, "serial")
    assert line is not None and "[modification.design] steps = 20" in line


def test_selective_assembly_of_a_measured_ring_counts_a_datasheet_per_class(tmp_path):
    """100 classes with a measured ring were estimated at 20 s and took 8 min, unwarned."""
    from corr_cad.geometry.profile import working_profile
    from corr_cad.run.budget.resources import Budget, time_warning

    t = np.linspace(0.0, 2 * np.pi, 5000, endpoint=False)
    pts = working_profile(GearDesign()).points(t)
    np.savetxt(tmp_path / "m.csv", pts, fmt="%.4f", delimiter=",", header="x,y", comments="")
    classes = ", ".join(f"{c:.1f}" for c in np.linspace(-5.0, 5.0, 100))
    (tmp_path / "s.toml").write_text(
        '[export]\nformats = ["datasheet"]\n[load]\ninput_torque = 1.1e5\n'
        '[errors]\nmeasured_profile = "m.csv"\n'
        f"[assembly]\nroller_classes_um = [{classes}]\ntarget_backlash_arcmin = 1.0\n"
    )
    scene = load_scene(tmp_path / "s.toml")
    est = estimate(scene, 1, "serial")
    one = est.stages["datasheet"].seconds
    assert est.stages["datasheet_files"].seconds >= 100 * one  # a datasheet a class
    budget = Budget(3 * 1024**3, 1024**3, 60.0, "default", "default", "default")
    line = time_warning(scene, est, budget, "serial")
    assert line is not None and "[assembly] roller_classes_um = 100 classes:" in line
