"""Solids: chord tolerance vs triangles, STL size, volume error and build time (gear ring).

Run:  python benchmarks/bench_mesh.py   (the same as: corr-cad bench --study solids)
Prints a table and writes CSV and PNG under outputs/bench/.
"""

import sys
from pathlib import Path

from corr_cad.run.bench.bench import run

if __name__ == "__main__":
    run(Path(__file__).resolve().parents[1] / "outputs" / "bench", ["solids"])
    sys.exit(0)
