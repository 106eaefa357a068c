"""A plane-stress body by finite elements (scikit-fem), reduced to influence coefficients.

Quadratic triangles (P2, :class:`skfem.ElementTriP2`) on the mesh of
:func:`corr_cad.mechanics.bodies.mesh.mesh_region`; plane stress (Timoshenko
and Goodier, *Theory of Elasticity*, 3rd ed., Sec. 16: ``lambda* = E nu /
(1 - nu^2)``, ``mu = E / (2 (1 + nu))``), thickness ``t``; one boundary held
(zero displacement). The stiffness is factorised once (SuperLU); a set of
unit loads is solved at once and read at a set of points along given
directions: the influence coefficients ``C[i, m]`` (mm/N), the displacement at
read point ``i`` along its direction under a unit load ``m``.

A load is spread over the boundary as Hertz's elliptic pressure of
half-width ``b`` (quadrature on 2 x 8 points just inside the boundary);
the displacement is read at a point ``depth`` below the surface, outside
the contact's own indentation (the contact law holds that).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import shapely
from scipy.sparse.linalg import splu
from skfem import Basis, ElementTriP2, ElementVector, MeshTri

__all__ = ["PlaneBody", "patch_nodes", "patch_weights"]

#: Quadrature of the elliptic pressure: Gauss-Chebyshev of the second kind, exact for
#: sqrt(1 - s^2) times a polynomial of degree 2 n - 1.
_PATCH_POINTS = 16
#: Points located at once by skfem's element finder (see ``PlaneBody._probe``).
_PROBE_BLOCK = 128


class PlaneBody:
    """A plane-stress body: mesh (points (N, 2), triangles (M, 3), boundary ``loops``:
    each boundary's point indices, outer first), the held loop, E, nu, t.

    Every node of ``loops[held]`` is held (zero displacement), and P2's edge
    nodes on its chords. ``held = None``: a free body, its rigid-body modes tied
    by a spring of ``1e-10`` of the mean diagonal stiffness at every node (for
    self-equilibrated loads, which it does not feel).
    """

    def __init__(
        self,
        points: np.ndarray,
        triangles: np.ndarray,
        loops: list[np.ndarray],
        held: int | None,
        young_modulus: float,
        poisson_ratio: float,
        thickness: float,
    ):
        self.region = shapely.Polygon(points[loops[0]], [points[lp] for lp in loops[1:]])
        self.mesh = MeshTri(np.ascontiguousarray(points.T), np.ascontiguousarray(triangles.T))
        # Three-point quadrature: exact for the P2 stiffness on straight-sided triangles.
        self.basis = Basis(self.mesh, ElementVector(ElementTriP2()), intorder=2)
        E, nu, t = young_modulus, poisson_ratio, thickness
        lam = E * nu / (1.0 - nu * nu)  # plane stress
        mu = E / (2.0 * (1.0 + nu))

        K = _stiffness(self.basis, lam, mu, t)
        if held is None:
            K = K + sp.identity(K.shape[0], format="csc") * (1e-10 * K.diagonal().mean())
            fixed = np.zeros(0, dtype=int)
        else:
            held_set = np.zeros(self.mesh.p.shape[1], dtype=bool)
            held_set[np.asarray(loops[held])] = True
            f = self.mesh.facets
            on = held_set[f[0]] & held_set[f[1]]
            fixed = self.basis.get_dofs(facets=np.flatnonzero(on)).all()
            fixed = np.union1d(fixed, self.basis.nodal_dofs[:, held_set].ravel())
        self.free = np.setdiff1d(np.arange(self.basis.N), fixed)
        self.lu = splu(
            K[self.free][:, self.free].tocsc(),
            permc_spec="MMD_AT_PLUS_A",
            diag_pivot_thresh=0.0,
            options={"SymmetricMode": True},
        )
        self.dofs = self.basis.N

    def _probe(self, points: np.ndarray, directions: np.ndarray) -> sp.csr_matrix:
        """(n, N): the displacement at ``points`` (n, 2) along ``directions`` (n, 2).

        A block of points at a time: skfem's element finder, where one point is not in
        the elements of its nearest centroids, searches every element for the whole
        block at once (points x elements coordinates), 700 MB for the prototype's frame
        read in one block; 128 points keep it near 40 MB."""
        rows = []
        for a in range(0, len(points), _PROBE_BLOCK):
            p, dv = points[a : a + _PROBE_BLOCK], directions[a : a + _PROBE_BLOCK]
            P = self.basis.probes(np.ascontiguousarray(p.T)).tocsr()
            n = len(p)
            rows.append(sp.diags(dv[:, 0]) @ P[:n] + sp.diags(dv[:, 1]) @ P[n:])
        return sp.vstack(rows).tocsr()

    def influence(
        self,
        load_points: np.ndarray,
        load_dirs: np.ndarray,
        load_tangents: np.ndarray,
        half_width: float,
        read_points: np.ndarray,
        read_dirs: np.ndarray,
    ) -> np.ndarray:
        """Influence coefficients (n_read, n_load), mm/N.

        Load ``m``: a unit force along ``load_dirs[m]`` spread as Hertz's
        pressure over ``+-half_width`` along ``load_tangents[m]`` about
        ``load_points[m]`` (a straight stretch of the boundary; the quadrature
        points are moved 10 % of the half-width into the body, along the force).
        """
        s = patch_nodes()
        patch = (
            load_points[:, None, :]
            + half_width * s[None, :, None] * load_tangents[:, None, :]
            + 0.1 * half_width * load_dirs[:, None, :]
        )
        return self.influence_patches(patch, load_dirs, read_points, read_dirs)

    def influence_patches(
        self,
        patches: np.ndarray,
        load_dirs: np.ndarray,
        read_points: np.ndarray,
        read_dirs: np.ndarray,
    ) -> np.ndarray:
        """Influence coefficients (n_read, M) of loads at the quadrature points
        ``patches`` (M, k, 2) of :func:`patch_nodes` along ``load_dirs`` (M, 2)."""
        M, k = patches.shape[:2]
        w = patch_weights(k)
        # A point of the outline may lie a chord's sagitta outside the mesh (a convex
        # tooth tip): moved along its force, into the body, until inside.
        span = np.linalg.norm(patches[:, 0] - patches[:, -1], axis=1)
        toward = patches.mean(axis=1) + span[:, None] * np.asarray(load_dirs, dtype=float)
        patches = self._inside(patches, toward)
        dirs = np.repeat(np.asarray(load_dirs, dtype=float), k, axis=0)
        Pq = self._probe(patches.reshape(-1, 2), dirs)  # (M k, N)
        W = sp.kron(sp.eye(M), sp.csr_matrix(w[None, :]))  # (M, M k)
        F = (W @ Pq).tocsr()[:, self.free]  # (M, n_free): each patch's consistent loads
        Rd = self._probe(np.asarray(read_points, dtype=float), np.asarray(read_dirs, dtype=float))
        Rd = Rd.tocsc()[:, self.free]
        # K is symmetric: solve for whichever side has fewer columns (one column at a
        # time: SuperLU's solve of a 2D right-hand side is several times slower).
        if M <= Rd.shape[0]:
            return np.asarray(Rd @ self._solve(F.T.tocsc()))
        return np.asarray(F @ self._solve(Rd.T.tocsc())).T

    def _inside(self, pts: np.ndarray, toward: np.ndarray) -> np.ndarray:
        """``pts`` (M, k, 2) each moved towards ``toward`` (M, 2) until inside the mesh."""
        out = pts.copy()
        for lam in (0.0, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1):
            moved = pts + lam * (toward[:, None, :] - pts)
            flat = out.reshape(-1, 2)
            bad = ~shapely.contains_xy(self.region, flat[:, 0], flat[:, 1])
            if not np.any(bad):
                break
            flat[bad] = moved.reshape(-1, 2)[bad]
        return out

    def _solve(self, rhs: sp.csc_matrix) -> np.ndarray:
        """``K^-1 rhs`` (n_free, m) for sparse columns ``rhs``."""
        out = np.empty(rhs.shape, order="F")
        for j in range(rhs.shape[1]):
            out[:, j] = self.lu.solve(rhs[:, [j]].toarray().ravel())
        return out


def _stiffness(basis: Basis, lam: float, mu: float, t: float) -> sp.csc_matrix:
    """The plane-stress stiffness, ``t int eps(v) : D eps(u)``, assembled element by
    element with one einsum (skfem's quadrature and shape-function gradients)."""
    # Voigt strains (xx, yy, 2 xy) of each shape function: (Nbfun, 3, elements, points).
    eps = np.stack(
        [
            np.stack([g[0, 0], g[1, 1], g[0, 1] + g[1, 0]])
            for g in (phi[0].grad for phi in basis.basis)
        ]
    )
    D = np.array([[lam + 2 * mu, lam, 0.0], [lam, lam + 2 * mu, 0.0], [0.0, 0.0, mu]])
    De = np.einsum("ab,jbeq->jaeq", D, eps) * (t * basis.dx)
    n, _, ne, nq = eps.shape
    A = eps.transpose(2, 0, 1, 3).reshape(ne, n, 3 * nq)
    B = De.transpose(2, 0, 1, 3).reshape(ne, n, 3 * nq)
    Ke = np.matmul(A, B.transpose(0, 2, 1)).transpose(1, 2, 0)  # (Nbfun, Nbfun, elements)
    dofs = basis.element_dofs
    rows = np.broadcast_to(dofs[:, None, :], Ke.shape).ravel()
    cols = np.broadcast_to(dofs[None, :, :], Ke.shape).ravel()
    return sp.coo_matrix((Ke.ravel(), (rows, cols)), shape=(basis.N, basis.N)).tocsc()


def patch_nodes(k: int = _PATCH_POINTS) -> np.ndarray:
    """Gauss-Chebyshev (second kind) nodes on (-1, 1), (k,)."""
    j = np.arange(1, k + 1)
    return np.cos(j * np.pi / (k + 1))


def patch_weights(k: int = _PATCH_POINTS) -> np.ndarray:
    """Their weights for Hertz's pressure ``sqrt(1 - s^2)``, summing to 1, (k,)."""
    j = np.arange(1, k + 1)
    w = np.sin(j * np.pi / (k + 1)) ** 2
    return w / w.sum()
