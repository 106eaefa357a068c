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


def pytest_configure(config):
    """Compile the numerical kernels numba's cache lacks once, before any test (and,
    under xdist, before the workers start): the suite pays the first-run compile at most
    once, never in several workers at the same time."""
    if hasattr(config, "workerinput"):
        return  # an xdist worker: the controller warmed them
    import subprocess
    import sys

    from corr_cad.run.warmup import missing

    if missing():
        subprocess.run([sys.executable, "-m", "corr_cad", "warm-up"], check=False)


@pytest.fixture(scope="session")
def prototype() -> GearDesign:
    """The paper's Table 1 design."""
    return GearDesign()
