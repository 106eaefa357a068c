"""Write a synthetic CMM measurement of the prototype ring and a scene that inspects it.

The profile is the closed form (roller centre s = e cos psi + sqrt(L^2 - e^2 sin^2 psi),
psi = z t, working profile = outer offset by r) with known faults: tooth space 5 turned
by +10 arcsec, a 4 um bump (material added) on one flank of tooth space 12, the teeth
5 um off the CMM origin, and 0.5 um of noise. 60 points per tooth.

    python benchmarks/synthetic_cmm.py outputs/cmm_demo
    corr-cad run outputs/cmm_demo/inspect.toml --out outputs/cmm_demo/out
"""

import math
import sys
from pathlib import Path

import numpy as np

Z, E, L, R = 25, 3.5, 143.0, 8.0
PITCH = 2 * math.pi / Z
M = 60


def working(t):
    psi = Z * t
    w = np.sqrt(L * L - (E * np.sin(psi)) ** 2)
    s = E * np.cos(psi) + w
    ds = -Z * E * np.sin(psi) * s / w
    ur = np.stack([np.sin(t), np.cos(t)], -1)
    ut = np.stack([np.cos(t), -np.sin(t)], -1)
    n = s[:, None] * ur - ds[:, None] * ut
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return s[:, None] * ur + R * n, n


def turn(p, a):
    c, s = math.cos(a), math.sin(a)
    return np.stack([p[:, 0] * c + p[:, 1] * s, -p[:, 0] * s + p[:, 1] * c], 1)


def main(folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    t_loc = (np.arange(M) + 0.5) / M * PITCH - PITCH / 2
    pts = []
    for k in range(Z):
        p, n = working(t_loc + k * PITCH)
        if k + 1 == 12:
            psi = Z * t_loc
            bump = 4e-3 * np.exp(-(((psi - math.radians(60)) / math.radians(12)) ** 2))
            p = p - bump[:, None] * n
        if k + 1 == 5:
            p = turn(p, math.radians(10 / 3600))
        pts.append(p)
    pts = np.vstack(pts) + np.array([0.004, -0.003])
    pts += np.random.default_rng(1).normal(0, 0.5e-3, pts.shape)
    (folder / "cmm_points.csv").write_text(
        "x,y\n" + "\n".join(f"{x:.6f},{y:.6f}" for x, y in pts) + "\n"
    )
    (folder / "inspect.toml").write_text(
        '[export]\nformats = ["inspection"]\n[errors]\nmeasured_profile = "cmm_points.csv"\n'
        "[inspection]\nprofile_tolerance = 0.003\nposition_tolerance_arcsec = 5.0\n"
        "single_pitch_tolerance_arcsec = 8.0\ncumulative_pitch_tolerance_arcsec = 30.0\n"
        "runout_tolerance = 0.015\n[load]\ninput_torque = 1.1e5\n[solver]\npositions = 3600\n"
    )
    print(f"wrote {folder / 'cmm_points.csv'} ({len(pts)} points) and {folder / 'inspect.toml'}")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "outputs/cmm_demo"))
