"""What a drive Monte Carlo sample costs on the chain: rigid, the crankshaft, the elastic
bodies (CPU seconds a sample; costs_montecarlo.CHAIN_FACTORS, docs/physics.md).

    PYTHONPATH=. python benchmarks/bench_chain_samples.py 20 rigid crank bodies
    PYTHONPATH=. python benchmarks/bench_chain_samples.py 4 rigid crank bodies --datasheet

The prototype with Palmgren's law, a 1 um (1 sigma) roller tolerance, 72 positions a
sample (8 with ``--datasheet``, whose pass takes 4 positions a mesh), the cams fixed, on
40 needles and on 40 needles with 5 um of clearance; the crank as derived from the design,
the bodies' tables of the prototype (computed into the user's cache once).
"""

import sys
import time

from corr_cad import GearDesign
from corr_cad.geometry.parts import part_outlines
from corr_cad.geometry.profile import undercut_analysis, working_profile
from corr_cad.mechanics.crank.bearing import EccentricBearing
from corr_cad.mechanics.datasheet import DatasheetSpec
from corr_cad.run.scene.scene import parse_scene
from corr_cad.run.stages.stages_bodies import cached_tables
from corr_cad.tolerance.mc_datasheet import DatasheetMC
from corr_cad.tolerance.montecarlo import Distribution, monte_carlo


def main(n: int, chains: list[str], datasheet: bool) -> None:
    d = GearDesign()
    tables, _ = cached_tables(d, part_outlines(d, working_profile(d, undercut_analysis(d)), 0.001))
    crank = parse_scene(
        {"solver": {"model": "drive"}, "load": {"input_torque": 1.1e5}, "crankshaft": {}}
    ).crank
    tol = {"roller_radius": Distribution("normal", 0.001)}
    sheet = DatasheetMC(DatasheetSpec(rated_torque=2.86e6), positions_per_mesh=4)
    positions = 8 if datasheet else 72
    cases = (
        ("fixed", None),
        ("needles", EccentricBearing(40, 6.0, 12.0)),
        ("needles 5 um", EccentricBearing(40, 6.0, 12.0, 0.005)),
    )
    for name, bearing in cases:
        for chain in chains:
            drive = {"bearing": bearing, "contact_model": "palmgren"}
            if chain == "crank":
                drive["crank"] = crank
            elif chain == "bodies":
                drive["bodies"] = tables
            kw = {"drive": drive, "datasheet": sheet if datasheet else None}
            monte_carlo(d, 1.1e5, tol, 1, 1, positions, **kw)  # compiled, warm
            t = time.process_time()
            monte_carlo(d, 1.1e5, tol, n, 1, positions, **kw)
            ms = 1e3 * (time.process_time() - t) / n
            print(f"{name:14s} {chain:7s} {ms:8.2f} ms a sample", flush=True)


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    main(int(args[0]), args[1:] or ["rigid", "crank", "bodies"], "--datasheet" in sys.argv)
