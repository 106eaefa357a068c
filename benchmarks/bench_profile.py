"""Profile export: tolerance vs measured deviation, size and time, per representation.

Run:  python benchmarks/bench_profile.py   (the same as: corr-cad bench --study profile)
Prints a table and writes CSV and PNG under outputs/bench/.
"""

import sys
from pathlib import Path

from corr_cad.run.bench.bench import run

if __name__ == "__main__":
    run(Path(__file__).resolve().parents[1] / "outputs" / "bench", ["profile"])
    sys.exit(0)
