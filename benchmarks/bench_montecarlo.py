"""Monte Carlo: confidence-interval width vs samples, and throughput on a process pool.

Run:  python benchmarks/bench_montecarlo.py
      (the same as: corr-cad bench --study montecarlo --study throughput)
Prints tables and writes CSV and PNG under outputs/bench/.
"""

import sys
from pathlib import Path

from corr_cad.run.bench.bench import run

if __name__ == "__main__":
    run(Path(__file__).resolve().parents[1] / "outputs" / "bench", ["montecarlo", "throughput"])
    sys.exit(0)
