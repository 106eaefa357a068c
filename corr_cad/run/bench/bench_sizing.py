"""Benchmark of the design search: evaluations per second of ``templates/sizing.toml``.

``corr-cad bench --study sizing``. The target: a default search (about 2,000
evaluations) of the second stage with its needle bearing within 10 minutes
on 2 cores. Measured two ways, never asserted: a fresh ``python -m corr_cad
size`` of the template on a 2-worker pool (wall time and the candidates per
second it reached, with the stage's fixed costs: the workers' start and the front
evaluated again; which a shared machine's load slows), and the CPU time of
one screened candidate in this process (which load does not inflate: two
idle cores evaluate about ``2 / CPU time`` candidates per second), from which
the time 2,000 evaluations take.
"""

from __future__ import annotations

import json
import os
import tempfile
import time
from pathlib import Path

from corr_cad.run.bench.bench_common import _table, _write_csv

__all__ = ["sizing_speed"]

TEMPLATE = Path(__file__).resolve().parents[3] / "templates" / "sizing.toml"


def _cpu_per_candidate(n: int) -> float:
    """Median CPU seconds of one screened candidate of the template, in this process."""
    import statistics
    import tomllib

    from corr_cad.run.scene.scene import parse_scene
    from corr_cad.run.stages.sizing_candidates import candidate_data, evaluate

    sz = parse_scene(tomllib.loads(TEMPLATE.read_text()), "sizing").sizing
    req, levels = sz["requirements"], sz["variables"]
    times = []
    for k in range(n + 1):
        values = {name: v[(k * 7 + 3 * i) % len(v)] for i, (name, v) in enumerate(levels.items())}
        data = candidate_data(sz["base"], values, req, True, False)
        t0 = time.process_time()
        evaluate(data, req)
        if k:  # the first loads the stages
            times.append(time.process_time() - t0)
    return statistics.median(times)


def sizing_speed(out: Path, quick: bool = False) -> list:
    """Candidates per second of the template's search, and the 2,000-evaluation projection."""
    import subprocess
    import sys

    n = 20 if quick else 60
    cpu = _cpu_per_candidate(3 if quick else 8)
    with tempfile.TemporaryDirectory() as tmp:
        scene = Path(tmp) / "s.toml"
        scene.write_text(
            TEMPLATE.read_text().replace("evaluations = 60 ", f"evaluations = {n} "),
            encoding="utf-8",
        )
        cmd = [sys.executable, "-m", "corr_cad", "size", str(scene), "--out",
               str(Path(tmp) / "o"), "--quiet", "--workers", "2"]  # fmt: skip
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True)
        wall = time.perf_counter() - t0
        m = json.loads((Path(tmp) / "o" / "manifest.json").read_text(encoding="utf-8"))
        stage = sum(s["seconds"] for s in m["stages"] if s["name"] == "sizing")
    load = os.getloadavg()[0]
    rate = m["sizing"]["evaluations"] / stage
    rows = [
        ["pool of 2, measured (whole stage: workers' start and the front's second pass)", n,
         wall, stage, rate, "", load],
        ["2 idle cores, from the CPU time of a candidate", n, "", cpu, 2 / cpu,
         2000 * cpu / 2 / 60, load],
    ]  # fmt: skip
    header = ["how", "evaluations", "wall_s", "stage_s_or_cpu_s", "evaluations_per_s",
              "minutes_for_2000", "load_avg_1min"]  # fmt: skip
    _table("design search of templates/sizing.toml (second stage + needle bearing)", header, rows)
    _write_csv(out, "sizing_speed.csv", header, rows)
    return rows
