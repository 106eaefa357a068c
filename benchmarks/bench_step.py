"""Where the time of a STEP export goes, per phase (CPU seconds, median of runs).

    python benchmarks/bench_step.py [--runs 3]

Designs: the paper's prototype (z = 25) and a z = 39 drive near its undercut
limit (Rj = 150, e = 3, r = 5.35). Phases as the ``step_files`` stage runs
them: the four part files written and read back (Open CASCADE's shape
healing off, GProp volume and area, optimal bounding box), then one assembly
file. CPU time (``time.process_time``) so that a busy machine distorts less;
the OCP import is measured once, in a fresh process.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from corr_cad import GearDesign, approximate, working_profile
from corr_cad.geometry.parts import part_outlines
from corr_cad.geometry.placement import assembly_placements

NAMES = {"ring": "inner_gear", "cam": "disk_cam", "roller": "roller", "frame": "teeth_frame"}
DESIGNS = {
    "prototype (z=25)": GearDesign(),
    "z=39 near undercut": GearDesign(
        tooth_count=39, cam_radius=150.0, eccentricity=3.0, roller_radius=5.35
    ),
}


def import_seconds() -> float:
    code = (
        "import time; t = time.process_time(); "
        "from corr_cad.export import step; step.require_ocp(); print(time.process_time() - t)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def phases(design: GearDesign, out: Path, tol: float = 1e-3) -> dict[str, float]:
    from corr_cad.export import step

    step.require_ocp()
    pt = time.process_time
    t: dict[str, float] = {}

    def add(key, t0):
        t[key] = t.get(key, 0.0) + pt() - t0

    w = working_profile(design)
    t0 = pt()
    spline = approximate(w, "spline", tol)
    part_outlines(design, w, tol)
    add("spline + exact volumes", t0)
    t0 = pt()
    shapes = step.part_shapes(design, spline)
    add("build B-rep", t0)
    for key, shape in shapes.items():
        t0 = pt()
        path = step.write_step(shape, out / f"{NAMES[key]}.step", NAMES[key])
        add("write 4 parts", t0)
        t0 = pt()
        _, parts = step.read_step(path, heal=False)
        add("read 4 parts", t0)
        t0 = pt()
        step.mass_properties(parts[0].shape)
        step.bounding_box(parts[0].shape)
        add("GProp + bbox", t0)
    t0 = pt()
    path = step.write_assembly_step(
        shapes, NAMES, assembly_placements(design, 0.0), out / "assembly.step", "assembly"
    )
    add("write assembly", t0)
    t0 = pt()
    _, parts = step.read_step(path, heal=False)
    # As the stage checks it: one box per product, every instance's location.
    boxes = {}
    for p in parts:
        if p.product not in boxes:
            boxes[p.product] = step.bounding_box(step.unplaced(p.shape))
        step.transform_points(p.shape, np.repeat(boxes[p.product], 4, axis=0))
    add("read + check assembly", t0)
    return t


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=3)
    args = ap.parse_args()
    imp = statistics.median(import_seconds() for _ in range(args.runs))
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        for label, design in DESIGNS.items():
            runs = [phases(design, Path(tmp)) for _ in range(args.runs)]
            rows[label] = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
    keys = list(next(iter(rows.values())))
    print(f"| phase (CPU s, median of {args.runs}) | " + " | ".join(rows) + " |")
    print("|---|" + "---|" * len(rows))
    print(f"| import OCP (fresh process) | {imp:.2f} |" + " |" * (len(rows) - 1))
    for k in keys:
        print(f"| {k} | " + " | ".join(f"{rows[r][k]:.2f}" for r in rows) + " |")
    parts = [k for k in keys if "assembly" not in k]
    print(
        "| **parts, read back (with import)** | "
        + " | ".join(f"**{imp + sum(rows[r][k] for k in parts):.2f}**" for r in rows)
        + " |"
    )
    print(
        "| **with the assembly** | "
        + " | ".join(f"**{imp + sum(rows[r].values()):.2f}**" for r in rows)
        + " |"
    )


if __name__ == "__main__":
    main()
