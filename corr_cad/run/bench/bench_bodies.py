"""Benchmark of the elastic ring and frame (``[solver] bodies = "elastic"``), timed.

``corr-cad bench --study bodies``. The targets: on the prototype, the finite-element
reduction of both bodies uncached in 10 s or less on 2 cores, read from the cache
in 0.2 s or less, and the elastic drive's 3,600 positions in at most twice the rigid
drive's time. Measured, never asserted; ``cpu_s`` is this process's CPU time, which
the shared machine's load cannot inflate.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from pathlib import Path

from corr_cad.geometry.design import GearDesign
from corr_cad.run.bench.bench_common import M0, _table, _write_csv
from corr_cad.run.bench.bench_drive import _load, _timed

__all__ = ["bodies_speed"]


def bodies_speed(out: Path, quick: bool = False) -> list:
    """Wall and CPU time of the bodies' reduction, its cache and the elastic drive."""
    from corr_cad.geometry.parts import part_outlines
    from corr_cad.geometry.profile import working_profile
    from corr_cad.mechanics.crank.bearing import EccentricBearing
    from corr_cad.mechanics.drive.drive import solve_drive
    from corr_cad.run.stages import stages_bodies

    design = GearDesign()
    outlines = part_outlines(design, working_profile(design), 0.001)
    repeat = 1 if quick else 3
    rows = []
    old = os.environ.get("CORR_CAD_CACHE_DIR")
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["CORR_CAD_CACHE_DIR"] = tmp
        try:
            t0, c0 = time.perf_counter(), time.process_time()
            tables, _ = stages_bodies.cached_tables(design, outlines)  # a new folder: computed
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
            rows.append(
                [
                    "FE reduction, ring, frame and cam, uncached",
                    *(wall, wall, wall, 10.0, "", cpu, _load()),
                ]
            )
            t = _timed(lambda: stages_bodies.cached_tables(design, outlines), repeat)
            rows.append(["FE tables read from the cache", *t[:3], 0.2, "", t[3], _load()])
        finally:
            if old is None:
                os.environ.pop("CORR_CAD_CACHE_DIR", None)
            else:
                os.environ["CORR_CAD_CACHE_DIR"] = old
    needles = EccentricBearing(40, 6.0, 12.0, 0.005)
    rounds = 1 if quick else 5
    for law in ("nonlinear", "palmgren"):
        for bearing in (None, needles):
            kind = "bearings" if bearing is not None else "cams fixed"

            def run(bodies=None, law=law, bearing=bearing):
                solve_drive(
                    design, M0, positions=3600, bearing=bearing, contact_model=law, bodies=bodies
                )

            # Interleaved, rigid then elastic in each round: the machine's load bears
            # on both alike; the medians of the rounds.
            run(), run(tables)  # warm-up
            rigid, elastic = [], []
            for _ in range(rounds):
                rigid.append(_timed(run, 1))
                elastic.append(_timed(lambda run=run: run(tables), 1))
            load = _load()
            r = [statistics.median(t[i] for t in rigid) for i in (0, 1, 2, 3)]
            e = [statistics.median(t[i] for t in elastic) for i in (0, 1, 2, 3)]
            r[1], r[2] = min(t[0] for t in rigid), max(t[0] for t in rigid)
            e[1], e[2] = min(t[0] for t in elastic), max(t[0] for t in elastic)
            rows.append([f"3600 positions rigid, {kind}, {law}", *r[:3], "", "", r[3], load])
            # CPU: what the machine's load inflates least
            ratio = e[3] / r[3]
            rows.append(
                [f"3600 positions elastic, {kind}, {law}", *e[:3], 2 * r[0], ratio, e[3], load]
            )
    header = [
        "case",
        "median_s",
        "min_s",
        "max_s",
        "target_s",
        "elastic_over_rigid_cpu",
        "cpu_s",
        "load_avg",
    ]
    nodes = " + ".join(str(n) for n in tables.nodes)
    _table(f"elastic bodies, prototype (ring + frame + cam: {nodes} nodes)", header, rows)
    _write_csv(out, "bodies_speed.csv", header, rows)
    return rows
