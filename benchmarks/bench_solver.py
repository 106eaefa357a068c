"""Force-solver speed: vectorised cycle vs a straightforward per-position scipy root-find.

Run:  python benchmarks/bench_solver.py   (the same as: corr-cad bench --study speed)
Prints a table and writes CSV and PNG under outputs/bench/.
"""

import sys
from pathlib import Path

from corr_cad.run.bench.bench import run

if __name__ == "__main__":
    run(Path(__file__).resolve().parents[1] / "outputs" / "bench", ["speed"])
    sys.exit(0)
