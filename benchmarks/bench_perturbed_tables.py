"""The elastic bodies' tables of the nominal design against tables rebuilt for one
perturbed sample's geometry (docs/physics.md, "Studies on samples on the chain").

The Monte Carlo solves every sample on the nominal design's influence tables. Here one
sample's errors (its cam radius, eccentricity and roller radius) are given their own
tables (its cam's outline, its rollers' load points; the ring and frame as drawn, the
same mesh sizes in mm) and the drive is solved on both: the relative difference of the
peak gear force, the mean crank rotation and the peak contact pressure.

    PYTHONPATH=. python benchmarks/bench_perturbed_tables.py
"""

import time
from dataclasses import replace

import numpy as np

from corr_cad import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors as ME
from corr_cad.geometry.parts import part_outlines
from corr_cad.geometry.profile import undercut_analysis, working_profile
from corr_cad.mechanics.bodies.reduction import MeshSpec, reduce_bodies
from corr_cad.mechanics.crank.bearing import EccentricBearing
from corr_cad.mechanics.drive.drive import solve_drive


def outlines(d, chord):
    return part_outlines(d, working_profile(d, undercut_analysis(d)), chord)


def compare(d, dRj, de, dr, T, positions, spec=None, chord=0.001, bearing=None, law="palmgren"):
    spec = spec or MeshSpec()
    o = outlines(d, chord)
    t0 = time.process_time()
    nominal = reduce_bodies(d, o, spec)
    # The sample's own geometry: its cam (radius + dRj) and its rollers' load points (its
    # eccentricity and roller radius); the ring and frame as drawn (their errors are none).
    dp = replace(
        d,
        cam_radius=d.cam_radius + dRj,
        eccentricity=d.eccentricity + de,
        roller_radius=d.roller_radius + dr,
    )
    op = {**o, "cam": outlines(dp, chord)["cam"]}
    spec_p = MeshSpec(
        spec.fine * d.roller_radius / dp.roller_radius,
        spec.grade,
        spec.coarse * d.roller_radius / dp.roller_radius,
        spec.half_width * d.roller_radius / dp.roller_radius,
        spec.depth * d.roller_radius / dp.roller_radius,
        spec.spacing * d.roller_radius / dp.roller_radius,
    )  # the same mesh in mm
    own = reduce_bodies(dp, op, spec_p)
    secs = time.process_time() - t0
    err = ME(cam_radius_error=dRj, eccentricity_error=de, roller_radius_error=dr)
    out = {}
    for name, tab in (("nominal", nominal), ("own", own)):
        res = solve_drive(
            d, T, positions=positions, errors=err, bearing=bearing, contact_model=law, bodies=tab
        )
        out[name] = (
            float(res.F_n.max()),
            float(np.mean(res.cam_rotation)),
            float(max(np.max([r.p_cam, r.p_slot, r.p_gear]) for r in res.rows)),
        )
    rel = [abs(a / b - 1) for a, b in zip(out["own"], out["nominal"], strict=False)]
    same = own.ring.shape == nominal.ring.shape
    top = float(np.max(np.abs(nominal.ring)))
    tab_rel = float(np.max(np.abs(own.ring - nominal.ring))) / top if same else float("nan")
    return out, rel, tab_rel, secs


if __name__ == "__main__":
    d = GearDesign()
    for dRj, de, dr in ((0.006, 0.006, 0.003), (0.03, 0.03, 0.015)):
        out, rel, tab_rel, secs = compare(
            d, dRj, de, dr, 1.1e5, 72, bearing=EccentricBearing(40, 6.0, 12.0, 0.005)
        )
        print(
            f"errors cam {dRj * 1e3:g} um, e {de * 1e3:g} um, roller {dr * 1e3:g} um:",
            out,
            "rel diff (F_n peak, mean tau, p peak):",
            [f"{x:.2e}" for x in rel],
            "ring table",
            f"{tab_rel:.2e}",
            "CPU s",
            round(secs, 1),
            flush=True,
        )
