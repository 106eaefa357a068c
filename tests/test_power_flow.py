"""The power balance of the running drive with friction, recomputed independently.

For an operating point (:func:`corr_cad.mechanics.losses.operating.operating_point`)
the test takes the contact forces (normal and friction) and the spins the
model settled on, and computes everything else with its own code: the
roller centres from the crank-slider ``s = e cos psi + sqrt(L^2 - e^2
sin^2 psi)``, their velocities by complex-step differentiation of that
placement in time, the contact points, the bodies' velocities there, each
contact's slip and loss ``-f . v_slip``, the needle bearing's loss ``0.5
mu P d |omega_crank - omega_cam|`` with ``P`` the resultant of the cam
forces, the crank's moment as the moment of the cam forces about the crank
axis and the output torque as the moment of the slot forces on the frame.
Then ``M_in (z + 1) - T_out = losses`` to 1e-9 at every position, and the
output torque's cycle mean is the load: at three torques, both directions,
with and without a preload.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.losses.efficiency import drive_friction, row_loads_from_forces
from corr_cad.mechanics.losses.friction import Friction
from corr_cad.mechanics.losses.operating import operating_point
from corr_cad.mechanics.row.windup import Windup, mesh_period_rad

D = GearDesign()
T_R = 2.86e6  # N*mm
X = mesh_period_rad(D) * np.arange(6) / 6
MU = Friction(0.06, 0.04, 0.05, 0.003, "bearing", 82.4)
PRELOAD = ManufacturingErrors(roller_radius_error=0.001)


def _perp(a):
    return np.stack([-a[..., 1], a[..., 0]], axis=-1)


def _cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _centres(phi, t):
    """Roller centres (P, R, 2) at time t (output speed 1, crank z + 1), complex-safe."""
    z, e, L = D.tooth_count, D.eccentricity, D.cam_radius + D.roller_radius
    R = z + 1
    theta = 2 * np.pi * np.arange(R) / R + t  # slots turn with the frame
    psi = (phi + (z + 1) * t)[:, None] - theta[None, :]
    s = e * np.cos(psi) + np.sqrt(L * L - (e * np.sin(psi)) ** 2)
    return np.stack([s * np.cos(theta), s * np.sin(theta)], axis=-1)


def _independent_balance(row, fr):
    """Per position: input power, output power and the losses, from forces and kinematics."""
    z, e, r = D.tooth_count, D.eccentricity, D.roller_radius
    phi = np.asarray(row.crank_angles, dtype=float)
    c = _centres(phi, 0.0)
    h = 1e-30
    v = np.imag(_centres(phi.astype(complex), 1j * h)) / h  # d centre / dt
    o1 = e * np.stack([np.cos(phi), np.sin(phi)], axis=-1)[:, None, :]
    # Contact directions from the roller centre: cam (towards the cam centre), slot
    # (along the frame's tangent, the side the slot force says), ring (outward normal
    # of the roller's path in the ring, perpendicular to its velocity relative to it).
    d_cam = (o1 - c) / np.linalg.norm(o1 - c, axis=-1, keepdims=True)
    ut = _perp(c / np.linalg.norm(c, axis=-1, keepdims=True))
    d_slot = np.where(np.asarray(row.slot_force)[..., None] < 0, -ut, ut)
    n_ring = -_perp(v) / np.linalg.norm(v, axis=-1, keepdims=True)
    n_ring = np.where(np.sum(n_ring * c, axis=-1, keepdims=True) < 0, -n_ring, n_ring)
    d = np.stack([d_cam, d_slot, n_ring], axis=2)
    N, f = fr.roller["N"], fr.roller["f"]
    force = -N[..., None] * d + f[..., None] * _perp(d)  # on each roller, (P, R, 3, 2)
    p = c[:, :, None, :] + r * d
    w_in, w_cam, w_r = z + 1.0, fr.cam_spin, fr.roller["spin"]
    body = np.stack(
        [
            w_in * _perp(o1) + w_cam[:, None, None] * _perp(p[:, :, 0] - o1),
            _perp(p[:, :, 1]),
            np.zeros_like(p[:, :, 2]),
        ],
        axis=2,
    )
    surface = v[:, :, None, :] + w_r[..., None, None] * r * _perp(d)
    slip = np.sum((surface - body) * _perp(d), axis=-1)
    contact_loss = np.sum(-f * slip, axis=(1, 2))
    assert np.all(-f * slip >= -1e-9 * np.abs(f * slip).max())  # friction opposes the slip
    crank_moment = np.sum(_cross(p[:, :, 0], force[:, :, 0]), axis=1)
    load = np.linalg.norm(np.sum(force[:, :, 0], axis=1), axis=-1)
    bearing = 0.5 * MU.mu_bearing * MU.bearing_diameter * load * np.abs(w_in - w_cam)
    output_torque = -np.sum(_cross(p[:, :, 1], force[:, :, 1]), axis=1)
    return crank_moment * w_in, output_torque, contact_loss + bearing


@pytest.mark.parametrize("errors", [None, PRELOAD], ids=["free", "preload"])
@pytest.mark.parametrize("backdriving", [False, True], ids=["forward", "backdriving"])
def test_power_balance_from_forces_and_slips(errors, backdriving):
    w = Windup(D, X, errors=errors)

    def evaluate(T):
        rows = [row_loads_from_forces(D, w.forces(T))]
        return rows, drive_friction(D, rows, MU)

    for share in (0.3, 0.6, 1.0):
        T = share * T_R
        op = operating_point(evaluate, T, backdriving, w.load_share, D.roller_count)
        if not op.matched:  # self-locking backdriving: no state at the load
            assert backdriving and errors is not None
            continue
        p_in, t_out, losses = _independent_balance(op.rows[0], op.frictions[0])
        scale = np.maximum(np.abs(p_in), np.abs(t_out))
        assert np.all(np.abs(p_in - t_out - losses) <= 1e-9 * scale)
        # The same output torque in both directions: the load's share, on average.
        sign = -1.0 if backdriving else 1.0
        assert np.mean(t_out) == pytest.approx(sign * w.load_share * T, rel=1e-9)
        # The model's own powers agree with the independent ones.
        assert np.allclose(op.crank_power, p_in, rtol=1e-9, atol=0)
        assert np.allclose(op.output_torque, t_out, rtol=1e-9, atol=1e-9 * scale.max())
        assert np.all(losses >= 0.0)


def test_load_independent_drag_enters_the_efficiency_exactly_without_friction():
    """mu = 0 and drag moments (M_in at the crank, T_out at the output): forward
    T / (T + T_out + M_in (z + 1)), backdriving 1 - (T_out + M_in (z + 1)) / T."""
    w = Windup(D, X)
    zero = Friction(0.0, 0.0, 0.0, 0.0, "bearing", 82.4)

    def evaluate(T):
        rows = [row_loads_from_forces(D, w.forces(T))]
        return rows, drive_friction(D, rows, zero)

    T, m_in, t_out = 0.5 * T_R, 500.0, 20000.0
    z1 = D.roller_count
    fwd = operating_point(evaluate, T, False, w.load_share, z1, drag=(m_in, t_out))
    back = operating_point(evaluate, T, True, w.load_share, z1, drag=(m_in, t_out))
    assert fwd.efficiency == pytest.approx(T / (T + t_out + m_in * z1), rel=1e-12)
    assert back.efficiency == pytest.approx(1.0 - (t_out + m_in * z1) / T, rel=1e-12)
    # The rollers carry the load and the output's drag: T + T_out forward, T - T_out back.
    assert np.mean(fwd.output_torque) == pytest.approx(w.load_share * (T + t_out), rel=1e-12)
    assert np.mean(back.output_torque) == pytest.approx(-w.load_share * (T - t_out), rel=1e-12)
    # An output drag above the load: self-locking backwards.
    locked = operating_point(evaluate, T, True, w.load_share, z1, drag=(0.0, 2 * T))
    assert locked.efficiency == -math.inf


@pytest.mark.parametrize("backdriving", [False, True], ids=["forward", "backdriving"])
def test_power_balance_of_both_rows_of_the_drive(backdriving):
    """The drive with 40-needle bearings and a preload: each row's balance on its own, and
    the output torque of both rows together the load."""
    from corr_cad.mechanics.crank.bearing import EccentricBearing
    from corr_cad.mechanics.drive.drive_windup import DriveWindup
    from corr_cad.mechanics.losses.efficiency import rows_from_drive

    bearing = EccentricBearing(needles=40, needle_diameter=6.0, needle_length=12.0)
    w = DriveWindup(D, X, errors=PRELOAD, bearing=bearing)

    def evaluate(T):
        rows = rows_from_drive(D, w.forces(T))
        return rows, drive_friction(D, rows, MU)

    T = 0.6 * T_R
    op = operating_point(evaluate, T, backdriving, 1.0, D.roller_count)
    assert op.matched and len(op.rows) == 2
    total = 0.0
    for row, fr in zip(op.rows, op.frictions, strict=True):
        p_in, t_out, losses = _independent_balance(row, fr)
        scale = np.maximum(np.abs(p_in), np.abs(t_out))
        assert np.all(np.abs(p_in - t_out - losses) <= 1e-9 * scale)
        total = total + t_out
    sign = -1.0 if backdriving else 1.0
    assert np.mean(total) == pytest.approx(sign * T, rel=1e-9)
