"""Wall and CPU time of fresh ``python -m corr_cad run SCENE``: two source trees, interleaved.

    git archive e2b7837 | tar -x -C /tmp/before        # the code before
    python benchmarks/bench_e2e.py templates/prototype.toml --before /tmp/before --runs 5

Each run starts in a neutral folder, so ``-m corr_cad`` imports the tree on
``PYTHONPATH`` and not the current directory. CPU is the child's user +
system time, pool workers included. The 1-minute load average is printed
after each round: on a shared machine wall times mean little without it.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def once(scene: Path, src: Path, out: Path, extra: list[str]) -> tuple[float, float]:
    env = dict(os.environ, PYTHONPATH=str(src))
    cmd = [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(out), "--quiet"]
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd + extra, env=env, check=True, capture_output=True, cwd=out.parent)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("scene", type=Path)
    ap.add_argument("--before", type=Path, required=True, help="source tree of the old code")
    ap.add_argument("--after", type=Path, default=Path(__file__).resolve().parents[1])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("extra", nargs="*", help="more options for corr-cad run (after --)")
    args = ap.parse_args()
    trees = {"before": args.before.resolve(), "after": args.after.resolve()}
    times: dict[str, list[tuple[float, float]]] = {k: [] for k in trees}
    loads = []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(args.runs):
            for key, src in trees.items():
                out = Path(tmp) / key
                times[key].append(once(args.scene.resolve(), src, out, args.extra))
            loads.append(os.getloadavg()[0])
    print(f"| code | wall s (median of {args.runs}) | min-max | CPU s |")
    print("|---|---|---|---|")
    for key, rows in times.items():
        wall = [w for w, _ in rows]
        cpu = [c for _, c in rows]
        print(
            f"| {key} ({trees[key]}) | {statistics.median(wall):.2f} | "
            f"{min(wall):.2f}-{max(wall):.2f} | {statistics.median(cpu):.2f} |"
        )
    print("load average after each round:", " ".join(f"{x:.2f}" for x in loads))


if __name__ == "__main__":
    main()
