import os
import signal

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

# A suite started as a background job (``&``, nohup, some CI runners) inherits
# SIGINT ignored, and every CLI process a test starts would inherit that too:
# the tests that press Ctrl-C on a run would then see it ignored. Python's own
# handler here means children start with the default disposition again.
signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(scope="session")
def prototype() -> GearDesign:
    """The paper's Table 1 design."""
    return GearDesign()
