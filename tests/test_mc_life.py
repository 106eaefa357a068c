"""Life percentiles under tolerances (corr_cad.tolerance.mc_life)."""

from __future__ import annotations

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.life import LifeSpec
from corr_cad.mechanics.losses.efficiency import friction_figures
from corr_cad.mechanics.losses.friction import Friction
from corr_cad.mechanics.row.windup import Windup
from corr_cad.tolerance.mc_life import life_percentiles, life_samples
from corr_cad.tolerance.montecarlo import Distribution

D = GearDesign()
T_R = 2.86e6
FR = Friction(0.05, 0.05, 0.05, 0.0025, "bearing", 82.4)


@pytest.mark.slow
def test_zero_tolerance_samples_reproduce_the_nominal_life():
    tol = {"roller_radius": Distribution("normal", 0.0)}
    lives = life_samples(D, ManufacturingErrors(), tol, 3, 1, LifeSpec(), FR, T_R)
    # The nominal design over one tooth pitch at 4 positions per mesh period.
    x = 2 * np.pi / D.tooth_count * np.arange(4 * D.roller_count) / (4 * D.roller_count)
    ff = friction_figures(D, Windup(D, x), T_R, FR, [1.0], [1.0], LifeSpec())
    for name, v in lives.items():
        assert np.allclose(v, ff.lives[name], rtol=1e-9), name


def test_roller_scatter_shortens_the_life_and_percentiles_are_ordered():
    tol = {"roller_radius": Distribution("normal", 0.001)}
    lives = life_samples(D, ManufacturingErrors(), tol, 12, 7, LifeSpec(), FR, T_R, draws=50)
    p = life_percentiles(lives)
    assert p["samples"] == 12
    for name in ("bearing_row1", "cam_row1", "ring_row1", "system"):
        assert p[name]["p5"] <= p[name]["p50"] <= p[name]["p95"]
    # The system is shorter-lived than any of its parts, sample by sample.
    parts = np.stack([v for k, v in lives.items() if k != "system"])
    assert np.all(lives["system"] < parts.min(axis=0))
    # Rollers of unequal size share the load unequally: the raceways' median life falls.
    nominal = life_samples(
        D,
        ManufacturingErrors(),
        {"roller_radius": Distribution("normal", 0.0)},
        1,
        7,
        LifeSpec(),
        FR,
        T_R,
    )
    assert p["ring_row1"]["p50"] < nominal["ring_row1"][0]
    # The same seed and draws give the same samples whatever the subset asked for.
    again = life_samples(D, ManufacturingErrors(), tol, 5, 7, LifeSpec(), FR, T_R, draws=50)
    assert np.array_equal(again["system"], lives["system"][:5])


@pytest.mark.slow
def test_montecarlo_run_reports_life_percentiles(tmp_path):
    import json

    from corr_cad.run.cli import main

    scene = tmp_path / "s.toml"
    scene.write_text(
        "[load]\ninput_torque = 1.1e5\n[export]\nformats = ['montecarlo']\n"
        "[tolerances]\nroller_radius = { normal = 0.001 }\n"
        "[montecarlo]\nsamples = 20\npositions = 26\n[life]\nmontecarlo_samples = 6\n"
    )
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--quiet"]) == 0
    life = json.loads((out / "montecarlo_summary.json").read_text())["life_h"]
    assert life["samples"] == 6
    assert life["system"]["p5"] <= life["system"]["p50"] <= life["system"]["p95"]
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["montecarlo"]["life_h"] == life


def test_life_with_a_monte_carlo_alone_has_an_effect_and_says_nothing():
    """[life] with a Monte Carlo (no datasheet) gives the life percentiles: no "has no
    effect" line; with neither format it has none, and says so."""
    from corr_cad.run.scene.scene import parse_scene

    data = {
        "export": {"formats": ["montecarlo"]},
        "load": {"input_torque": 1.1e5},
        "tolerances": {"roller_radius": {"normal": 0.001}},
        "life": {},
    }
    assert not [w for w in parse_scene(data).warnings if "[life]" in w]
    data["export"]["formats"] = ["dxf"]
    del data["tolerances"]
    assert [w for w in parse_scene(data).warnings if w.startswith("[life]")]
