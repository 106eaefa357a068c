"""The estimate of the stages that solve the scene's own design on the elastic bodies:
the FE reduction's seconds only when its tables are not in the cache, and the elastic
solve's factor on needle bearings (twice the rigid solve, not ten times): the datasheet
of an elastic drive on needles with a crank was estimated at 39 s and took 4-8 s, and
its run warned 'would take about 1m36s' for 37 s."""

from __future__ import annotations

import numpy as np
import pytest

from corr_cad.run.budget import costs_bodies
from corr_cad.run.budget.costs import ESTIMATORS
from corr_cad.run.scene.scene import parse_scene

NEEDLES = {"needles": 40, "needle_diameter": 6.0, "needle_length": 12.0}


def _scene(bodies: str, needles: bool):
    data = {
        "export": {"formats": ["forces", "datasheet"]},
        "load": {"input_torque": 1.1e5},
        "solver": {"model": "drive", "contact_law": "palmgren", "bodies": bodies},
    }
    if needles:
        data["bearings"] = {"eccentric": dict(NEEDLES)}
    return parse_scene(data)


@pytest.mark.parametrize("needles,factor", [(True, 2), (False, 10)])
@pytest.mark.parametrize("stage", ["forces", "datasheet"])
def test_elastic_stage_seconds_cached_and_on_needles(monkeypatch, tmp_path, stage, needles, factor):
    monkeypatch.setenv("CORR_CAD_CACHE_DIR", str(tmp_path))  # an empty cache
    rigid = ESTIMATORS[stage](_scene("rigid", needles), None).seconds
    elastic = _scene("elastic", needles)
    uncached = ESTIMATORS[stage](elastic, None).seconds
    monkeypatch.setattr(costs_bodies, "_cached", lambda scene: True)
    cached = ESTIMATORS[stage](elastic, None).seconds
    # The solve's share scales by the factor; the FE reduction: 10 s, 0.1 s when cached.
    base = 0.05
    np.testing.assert_allclose(uncached - cached, costs_bodies.BODIES_SECONDS - 0.1, rtol=1e-12)
    assert cached - 0.1 - base == pytest.approx(factor * (rigid - base), rel=0.05)


def test_the_cache_is_looked_up_under_the_scenes_own_key(monkeypatch, tmp_path):
    """_cached finds a table file written under the key body_tables would use."""
    from corr_cad.geometry.parts import part_outlines
    from corr_cad.geometry.profile import undercut_analysis, working_profile
    from corr_cad.mechanics.bodies.reduction import MeshSpec
    from corr_cad.run.stages.stages_bodies import body_key

    monkeypatch.setenv("CORR_CAD_CACHE_DIR", str(tmp_path))
    s = _scene("elastic", True)
    assert not costs_bodies._cached(s)
    d = s.design
    outlines = part_outlines(d, working_profile(d, undercut_analysis(d)), s.chord_tolerance)
    (tmp_path / "bodies").mkdir()
    (tmp_path / "bodies" / f"{body_key(d, outlines, MeshSpec())}.npz").write_bytes(b"x")
    assert costs_bodies._cached(s)


@pytest.mark.parametrize(
    "chain,said",
    [
        (None, None),
        (
            "every sample solved on the nominal drive's chain: the crankshaft on its support "
            "bearings as [crankshaft] and [bearings.crank] give it (one shaft for every sample)",
            "  every sample solved on the crankshaft on its support bearings (model.samples_chain)",
        ),
        (
            "every sample solved on the nominal drive's chain: the crankshaft ...; the elastic "
            "ring, frame and cams by the nominal design's influence tables",
            "  every sample solved on the crankshaft on its support bearings and the elastic "
            "ring, frame and cams (FE) (model.samples_chain)",
        ),
    ],
)
def test_the_monte_carlo_console_says_what_the_samples_solve_on(chain, said):
    """A Monte Carlo alone (no forces, no datasheet) said nothing of the crank or the
    elastic bodies on the console; the line comes from the manifest's samples_chain."""
    from corr_cad.run.console import summary_lines

    mc = {"samples": 16, "percentiles": {}}
    if chain is not None:
        mc["samples_chain"] = chain
    lines = summary_lines({"montecarlo": mc, "files": []}, "out")
    i = lines.index("Monte Carlo, 16 samples:")
    if said is None:
        assert not any("every sample solved on" in x for x in lines)
    else:
        assert lines[i + 1] == said


@pytest.mark.parametrize("formats", [["forces", "datasheet"], ["datasheet"], ["forces"]])
def test_the_fe_reduction_is_counted_once_a_run(monkeypatch, tmp_path, formats):
    """A run reduces the bodies in its first stage that solves on them; the datasheet after
    the forces reads the tables they cached, so the run's estimate counts 10 s once."""
    from dataclasses import replace

    from corr_cad.run.budget.resources import estimate

    monkeypatch.setenv("CORR_CAD_CACHE_DIR", str(tmp_path))  # an empty cache
    scene = replace(_scene("elastic", True), formats=tuple(formats))
    uncached = estimate(scene, workers=1, executor="serial")
    monkeypatch.setattr(costs_bodies, "_cached", lambda scene: True)
    cached = estimate(scene, workers=1, executor="serial")
    reduction = costs_bodies.BODIES_SECONDS - costs_bodies.BODIES_CACHED_SECONDS
    assert uncached.seconds - cached.seconds == pytest.approx(reduction, rel=1e-12)
    if "forces" in formats and "datasheet" in formats:  # the datasheet reads the tables
        sheet = uncached.stages["datasheet"].seconds - cached.stages["datasheet"].seconds
        assert sheet == pytest.approx(0.0, abs=1e-12)
