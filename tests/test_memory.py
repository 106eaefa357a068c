"""The CLI keeps freed memory for reuse (corr_cad/run/budget/memory.py): no page faults per solve.

Counted, not timed: ``ru_minflt`` of a second full-cycle solve in a fresh
process, with and without what ``corr-cad`` sets at start.
"""

import subprocess
import sys

import pytest

CODE = """
import resource, sys
{setup}
from corr_cad import GearDesign, solve_forces
d = GearDesign()
solve_forces(d, 1.1e5, positions=3600)
r0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(5):
    solve_forces(d, 1.1e5, positions=3600)
print((resource.getrusage(resource.RUSAGE_SELF).ru_minflt - r0) / 5)
"""


def _faults(setup: str) -> float:
    out = subprocess.run(
        [sys.executable, "-c", CODE.format(setup=setup)], capture_output=True, text=True, check=True
    )
    return float(out.stdout.split()[-1])


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc mallopt")
def test_cli_start_removes_the_page_faults_of_a_solve():
    plain = _faults("")
    after_cli = _faults(
        "import contextlib, io\nfrom corr_cad.run.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n    main(['schema'])"
    )
    assert after_cli < 20, (plain, after_cli)
    # Where it matters (glibc handing large blocks back to the system), a
    # solve faults on hundreds of fresh pages without it.
    if plain > 200:
        assert after_cli < plain / 10
