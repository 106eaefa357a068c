"""Monte Carlo metrics stay bit-identical to those of the code before the speed-up.

``tests/data/montecarlo_golden.json`` was written by the Monte Carlo of commit
a2b5611 (before issue 11's speed work); every metric is stored as
``float.hex`` so the comparison is exact, bit for bit.
"""

import json
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import pytest

from corr_cad import GearDesign
from corr_cad.deviations import ManufacturingErrors
from corr_cad.tolerance import Distribution, monte_carlo

GOLDEN = json.loads((Path(__file__).parent / "data" / "montecarlo_golden.json").read_text())


def _run(case: dict, executor=None, chunk: int = 5):
    tol = {k: Distribution(*v) for k, v in case["tolerances"].items()}
    return monte_carlo(
        GearDesign(),
        1.1e5,
        tol,
        case["samples"],
        case["seed"],
        case["positions"],
        chunk=chunk,
        base_errors=ManufacturingErrors(**case["base"]),
        executor=executor,
    )


def _hex(res) -> dict:
    return {
        "metrics": {k: [float(x).hex() for x in v] for k, v in res.metrics.items()},
        "magnitudes": {k: [float(x).hex() for x in v] for k, v in res.magnitudes.items()},
    }


@pytest.mark.parametrize("name", sorted(GOLDEN))
def test_bit_identical_to_golden(name):
    case = GOLDEN[name]
    res = _run(case)
    assert res.success == case["success"]
    got = _hex(res)
    assert got["magnitudes"] == case["magnitudes"]
    for metric, values in case["metrics"].items():
        assert got["metrics"][metric] == values, metric


def test_golden_on_a_process_pool_and_other_chunking():
    case = GOLDEN["four_kinds"]
    with ProcessPoolExecutor(2) as pool:
        res = _run(case, executor=pool, chunk=7)
    assert _hex(res)["metrics"] == case["metrics"]
