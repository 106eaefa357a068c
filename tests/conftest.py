import os

import pytest
from hypothesis import HealthCheck, settings

from corr_cad import GearDesign

settings.register_profile(
    "ci",
    deadline=None,
    max_examples=int(os.environ.get("CORR_CAD_EXAMPLES", "25")),
    suppress_health_check=[HealthCheck.too_slow],
    derandomize=True,
)
settings.load_profile("ci")


@pytest.fixture(scope="session")
def prototype() -> GearDesign:
    """The paper's Table 1 design."""
    return GearDesign()
