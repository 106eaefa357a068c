"""The way in is one pass: each size of a scene computed once, the estimate unchanged.

``tests/data/estimates_golden.json`` holds the estimate of every template and
of the heavy shapes (``tests/scene_size_cases.py``), and the refusal lines,
as they were when the structural limits and the estimate each computed the
sizes again.
"""

from __future__ import annotations

import collections
import dataclasses
import json

import pytest

import corr_cad.geometry.sampling as sampling
import corr_cad.run.scene.limits as limits
from corr_cad.run.budget.resources import budget_for, check_scene, estimate, time_warning
from corr_cad.run.scene.scene import load_scene
from tests.scene_size_cases import EXECUTORS, GOLDEN, REFUSED, numbers, refusal, scenes


@pytest.fixture(scope="module")
def cases(tmp_path_factory):
    return scenes(tmp_path_factory.mktemp("sizes"))


@pytest.fixture(scope="module")
def golden():
    return json.loads(GOLDEN.read_text())


def test_the_estimate_of_every_template_and_heavy_scene_is_unchanged(cases, golden):
    assert sorted(cases) == sorted(k for k in golden if not k.startswith("refused "))
    for name, path in cases.items():
        scene = load_scene(path)
        for ex in EXECUTORS:
            assert numbers(scene, 2 if ex == "process" else 1, ex) == golden[name][ex], (name, ex)


def test_every_refusal_line_is_unchanged(tmp_path, golden):
    scenes(tmp_path)  # writes wave.csv, which the wavy ones read
    for i, (name, text) in enumerate(REFUSED.items()):
        path = tmp_path / f"r{i}.toml"
        path.write_text(text)
        assert refusal(path) == golden["refused " + name], name


def _count(monkeypatch) -> collections.Counter:
    """Count the expensive calls of the way in (the design caches emptied first)."""
    limits._curvature_integrals.cache_clear()
    limits.modified_ratio.cache_clear()
    calls: collections.Counter = collections.Counter()

    def counted(module, name):
        real = getattr(module, name)

        def wrapper(*a, **k):
            calls[name] += 1
            return real(*a, **k)

        monkeypatch.setattr(module, name, wrapper)

    for name in ("tolerance_floors", "profile_vertices", "mesh_triangles", "_locus"):
        counted(limits, name)
    counted(sampling, "approximate")
    return calls


def _way_in(path):
    """What ``corr-cad run`` does before any stage: load, budget, check, time warning."""
    scene = load_scene(path)
    budget = budget_for(scene)
    est = check_scene(scene, 2, budget, "process")
    time_warning(scene, est, budget, "process")
    estimate(scene, 1, "serial")  # a second estimate reads the same sizes
    return scene


def test_each_size_of_a_wavy_step_scene_is_computed_once(cases, monkeypatch):
    calls = _count(monkeypatch)
    _way_in(cases["step wavy"])
    # The curvature integral once; the structural check once; the ring's
    # vertices at [export] tolerance and the STEP spline's control points
    # once each; the meshes once; the wavy ring and the nominal one
    # approximated once in each of the two representations (polyline, spline).
    assert calls == {
        "_locus": 1,
        "tolerance_floors": 1,
        "profile_vertices": 2,
        "mesh_triangles": 1,
        "approximate": 4,
    }


@pytest.mark.parametrize("template", ["prototype", "shop", "compound", "montecarlo_gate"])
def test_each_size_of_a_template_is_computed_once(cases, monkeypatch, template):
    calls = _count(monkeypatch)
    scene = _way_in(cases[f"template {template}"])
    meshed = limits._meshes(scene)
    assert calls["_locus"] == 1
    assert calls["tolerance_floors"] == 1
    assert calls["mesh_triangles"] == (1 if meshed else 0)
    assert calls["profile_vertices"] == 1 + ("step" in scene.formats)
    assert calls["approximate"] == 0  # no [modification]: the closed form alone


def test_a_changed_copy_of_a_scene_gets_its_own_sizes(cases):
    scene = load_scene(cases["template prototype"])
    fine = dataclasses.replace(scene, tolerance=scene.tolerance / 10)
    a, b = limits.scene_size(scene), limits.scene_size(fine)
    assert limits.scene_size(scene) is a
    assert b.profile_vertices > a.profile_vertices
    assert b.profile_vertices == limits.profile_vertices(
        fine.design, fine.representation, fine.tolerance, fine.modification
    )
