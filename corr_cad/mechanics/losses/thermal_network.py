"""Temperature in time: a lumped thermal network heated by the drive's losses.

Nodes ``i`` with heat capacities ``C_i`` (J/K), conductances ``G_ij`` (W/K)
between them and ``g_i`` to the ambient; the losses ``P`` (W) enter node 0
(the oil and the parts it wets)::

    C_i dT_i/dt = P delta_i0 - g_i (T_i - T_amb) - sum_j G_ij (T_i - T_j)

The losses depend on node 0's temperature through the oil's viscosity, so
the system is integrated numerically (SciPy's ``solve_ivp``, LSODA,
relative and absolute tolerances 1e-10), piece by piece between the
breakpoints of the speed programme. With one node of capacity ``C`` and
``g = h A`` (housing area ``A``, heat transfer coefficient ``h``) and a
constant loss the closed form is ``T = T_amb + P / (h A) (1 - exp(-t / tau))``,
``tau = C / (h A)``, which the tests pin.

Steady state (ISO/TR 14179-1's heat balance): the temperature at which the
losses equal the heat the housing gives off, ``P(T_0) = (T_0 - T_amb) /
R_00`` with ``R = K^-1`` the network's thermal resistance matrix
(``R_00 = 1 / (h A)`` for one node), solved by Brent's method.

Units: W, J/K, C, s.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from corr_cad.errors import SolverError

__all__ = ["ThermalNetwork", "one_node_closed_form"]

#: Highest temperature a steady search looks at, C (beyond: no steady state found).
MAX_SEARCH_C = 1000.0


def one_node_closed_form(t_s, power_W: float, capacity: float, hA: float, ambient_C: float):
    """``T(t)`` of one node from the ambient at ``t = 0`` under a constant loss."""
    t = np.asarray(t_s, dtype=float)
    return ambient_C + power_W / hA * (1.0 - np.exp(-t * hA / capacity))


@dataclass(frozen=True)
class ThermalNetwork:
    """Capacities ``C`` (J/K), conductances to the ambient ``g`` (W/K) and links ``(i, j, G)``."""

    capacities: tuple[float, ...]
    to_ambient: tuple[float, ...]
    links: tuple[tuple[int, int, float], ...] = ()

    def __post_init__(self):
        if len(self.capacities) != len(self.to_ambient) or not self.capacities:
            raise SolverError("thermal network: one capacity and one ambient conductance per node")
        if min(self.capacities) <= 0 or min(self.to_ambient) < 0 or sum(self.to_ambient) <= 0:
            raise SolverError(
                "thermal network: capacities must be > 0 J/K and the conductances to the "
                "ambient >= 0 W/K with at least one > 0, e.g. C = 50000 J/K, hA = 5 W/K"
            )

    def matrix(self) -> np.ndarray:
        """``K``: ``K T = P + g T_amb`` at steady state (W/K)."""
        k = np.diag(np.asarray(self.to_ambient, dtype=float))
        for i, j, g in self.links:
            k[i, i] += g
            k[j, j] += g
            k[i, j] -= g
            k[j, i] -= g
        return k

    def resistance(self) -> float:
        """``R_00``: node 0's rise per watt into node 0 at steady state, K/W."""
        return float(np.linalg.inv(self.matrix())[0, 0])

    def steady(self, loss_W: Callable[[float], float], ambient_C: float) -> float | None:
        """Node 0's steady temperature under ``loss_W(T_0)``; None past :data:`MAX_SEARCH_C`."""
        from scipy.optimize import brentq

        r = self.resistance()

        def f(t: float) -> float:
            return loss_W(t) * r - (t - ambient_C)

        if f(ambient_C) <= 0.0:
            return float(ambient_C)
        if f(MAX_SEARCH_C) > 0.0:
            return None
        return float(brentq(f, ambient_C, MAX_SEARCH_C, xtol=1e-10, rtol=1e-12))

    def simulate(
        self,
        times_s: np.ndarray,
        breakpoints_s: np.ndarray,
        loss_W: Callable[[float, float], float],
        ambient_C: float,
        start_C: float | None = None,
    ) -> np.ndarray:
        """Node temperatures (len(times_s), N) under ``loss_W(t, T_0)``, from ``start_C``.

        ``start_C`` every node's temperature at ``t = 0`` (default the
        ambient); ``breakpoints_s`` the programme's kinks, integrated across
        piece by piece.
        """
        from scipy.integrate import solve_ivp

        c = np.asarray(self.capacities, dtype=float)
        g = np.asarray(self.to_ambient, dtype=float)
        k = self.matrix()
        times = np.asarray(times_s, dtype=float)
        y = np.full(len(c), ambient_C if start_C is None else start_C, dtype=float)

        def rhs(t, T):
            q = g * ambient_C - k @ T
            q[0] += loss_W(t, T[0])
            return q / c

        out = np.full((len(times), len(c)), np.nan)
        end = float(times[-1])
        edges = np.unique(np.concatenate([[0.0, end], np.asarray(breakpoints_s, dtype=float)]))
        edges = edges[(edges >= 0.0) & (edges <= end)]
        out[times == 0.0] = y
        for a, b in zip(edges[:-1], edges[1:], strict=True):
            inside = (times > a) & (times <= b)
            te = np.union1d(times[inside], [b])
            sol = solve_ivp(rhs, (a, b), y, method="LSODA", rtol=1e-10, atol=1e-10, t_eval=te)
            if not sol.success:
                raise SolverError(f"thermal network: integration failed at {a:g} s ({sol.message})")
            out[inside] = sol.y.T[np.searchsorted(te, times[inside])]
            y = sol.y[:, -1]
        return out

    def time_constant_s(self) -> float:
        """``C / (h A)`` of a one-node network (the sum of capacities over ``sum g`` otherwise)."""
        return float(sum(self.capacities) / sum(self.to_ambient))
