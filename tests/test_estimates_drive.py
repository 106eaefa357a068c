"""The estimate of what the drive runs: a datasheet pulled in by a check."""

from __future__ import annotations

import pytest


def test_a_datasheet_pulled_in_by_min_efficiency_is_costed_with_its_friction_figures():
    """A drive datasheet that only ``[checks] min_efficiency`` asks for was estimated at its
    windup alone (0.46 s; the friction figures took 1.6 s of CPU): the friction's positions
    (the datasheet's span at ``[friction] positions_per_mesh``) at the drive's cell cost."""
    from corr_cad.run.budget.costs_friction import FRICTION_CELL_SECONDS
    from corr_cad.run.budget.resources import estimate
    from corr_cad.run.scene.scene import parse_scene

    base = {
        "export": {"formats": ["forces"]},
        "load": {"input_torque": 1.1e5},
        "solver": {"model": "drive", "contact_law": "palmgren"},
    }
    plain = estimate(parse_scene(base), 2, "process")
    checked = estimate(parse_scene({**base, "checks": {"min_efficiency": 0.5}}), 2, "process")
    sheet = {**base, "export": {"formats": ["forces", "datasheet"]}}
    windup = estimate(parse_scene(sheet), 2, "process").stages["datasheet"].seconds
    assert "datasheet" not in plain.stages
    # 4 friction positions (a mesh period of the nominal drive) x 26 rollers x 10 (the drive)
    # at 1.5 ms: 1.56 s, what the figures took (1.6 s of CPU)
    assert checked.stages["datasheet"].seconds - windup == pytest.approx(1.56, rel=1e-9)
    assert FRICTION_CELL_SECONDS == 1.5e-3


@pytest.mark.parametrize("chain", ["crank", "bodies"])
def test_studies_on_samples_are_costed_on_the_chain(chain):
    """The Monte Carlo, allocation and sweeps of a drive on the crank or the elastic bodies
    cost the chain's factor more than on the rigid chain (measured per sample,
    costs_montecarlo.CHAIN_FACTORS); 2,000 samples that stay under the time warning on
    the rigid chain are said up front to take long on the crank or bodies."""
    from corr_cad.run.budget.costs_montecarlo import (
        CHAIN_FACTORS,
        CHAIN_FORCE_SECONDS,
        DRIVE_FORCE_SECONDS,
    )
    from corr_cad.run.budget.resources import Budget, estimate, time_warning
    from corr_cad.run.scene.scene import parse_scene

    base = {
        "export": {"formats": ["montecarlo", "allocation", "sweeps"]},
        "load": {"input_torque": 1.1e5},
        "solver": {"model": "drive", "contact_law": "palmgren"},
        "tolerances": {"roller_radius": {"normal": 0.001}},
        "checks": {"max_gear_force": 5000.0},
        "montecarlo": {"samples": 2000, "positions": 72},
        "sweeps": {"points": 5, "positions": 72},
    }
    extra = (
        {"crankshaft": {}}
        if chain == "crank"
        else {"solver": {**base["solver"], "bodies": "elastic"}}
    )
    rigid_scene, chain_scene = parse_scene(base), parse_scene({**base, **extra})
    rigid = estimate(rigid_scene, 2, "process")
    on = estimate(chain_scene, 2, "process")
    # the cams fixed; the chain's samples do not take the rigid chain's compiled force pass
    base = CHAIN_FORCE_SECONDS["palmgren"][0] / DRIVE_FORCE_SECONDS["palmgren"][0]
    factor = CHAIN_FACTORS[chain]["force"][0] * base
    mc = lambda e: e.stages["montecarlo"].seconds - 1.0  # noqa: E731 - less the fixed second
    assert mc(on) - 1e-6 * 72 * 26 == pytest.approx(factor * (mc(rigid) - 1e-6 * 72 * 26))
    assert on.stages["allocation"].seconds > 0.7 * factor * rigid.stages["allocation"].seconds
    assert on.stages["sweeps"].seconds > rigid.stages["sweeps"].seconds
    budget = Budget()
    assert time_warning(rigid_scene, rigid, budget) is None
    line = time_warning(chain_scene, on, budget)
    assert line is not None and line.startswith("the run would take about")
