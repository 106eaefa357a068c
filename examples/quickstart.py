"""Quickstart: design -> profile -> DXF -> forces -> Monte Carlo, from Python.

Run it with ``python examples/quickstart.py [OUT_DIR]`` (default
``outputs/quickstart``). Every number it prints comes from the library's
own calls; docs/api.md explains each step.
"""

from __future__ import annotations

import sys
from pathlib import Path

import corr_cad as cc


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)

    # 1. A design: the paper's Table 1 prototype with a 39-tooth ring instead.
    design = cc.GearDesign(tooth_count=39, cam_radius=135.0, roller_radius=6.0, eccentricity=2.0)
    r_max = cc.admissible_roller_radius(design)
    print(f"z = {design.tooth_count}: rollers up to {r_max:.3f} mm have no undercut (r = 6 mm)")

    # 2. The exact working profile, and a machining approximation measured against it.
    profile = cc.working_profile(design)
    arcs = cc.approximate(profile, "arcs", 0.001)
    print(f"arcs: {len(arcs.vertices)} vertices, measured deviation {arcs.max_deviation:.2e} mm")

    # 3. DXF files through the scene runner (the same code as `corr-cad run`).
    scene = cc.Scene(name="quickstart", design=design, formats=("dxf",), representation="arcs")
    manifest = cc.run_scene(scene, out)
    print(f"wrote {', '.join(sorted(manifest['files']))} to {out}")

    # 4. Mesh forces over one cycle, every roller.
    res = cc.solve_forces(design, 1.1e5, positions=720)
    k, j = divmod(int(res.F_n.argmax()), res.F_n.shape[1])
    print(
        f"peak gear force {res.F_n.max():.0f} N on roller {j + 1} at crank angle "
        f"{res.crank_angles[k] * 180 / 3.141592653589793:.1f} deg; "
        f"{res.loaded_count.min()}-{res.loaded_count.max()} rollers loaded"
    )

    # 5. Monte Carlo over a roller-radius tolerance (sigma 1 um per roller).
    tol = {"roller_radius": cc.Distribution("normal", 0.001)}
    mc = cc.monte_carlo(design, 1.1e5, tol, samples=100, seed=1, positions=72)
    s = mc.summary(cc.Checks(max_gear_force=2.0 * float(res.F_n.max())))
    p95 = s["percentiles"]["peak_gear_force"]["p95"]
    fail = s["failure_probability"]["max_gear_force"]
    print(f"Monte Carlo: p95 peak gear force {p95:.0f} N, P(F_n > 2 x nominal) = {fail:.0%}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("outputs") / "quickstart")
