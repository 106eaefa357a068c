"""The bodies in the drive's solve: influence matrices and the coupled equilibrium.

At each crank position the bodies add to roller ``k``'s overlap (along its
cam line, :mod:`corr_cad.mechanics.drive.drive`) the approach::

    d_k = sum_j C_kj F_j,
    C_kj = rho_n,k rho_n,j G_ring(k, j) + G_cam(k, j)   (k and j in one row)
         + |rho_s,k| |rho_s,j| G_frame(k, j) / 4         (/ 2 in one row)

where ``G_ring(k, j)`` is the ring's displacement along roller ``k``'s gear
normal under a unit gear force of roller ``j`` (both rows' rings are bodies of
their own) and ``G_frame`` one frame plate's displacement along roller ``k``'s
slot force under roller ``j``'s: each roller rests on the two plates it runs
through (its row's outer plate and the middle plate shared by both rows), half
its slot force on each, and moves by their mean; ``rho_n = F_n / F_j`` and
``rho_s = F_s / F_j`` turn the gear and slot approaches into the cam line's, as
the contact law does (the principle of virtual work); ``G_cam(k, j)`` is the
cam's approach along roller ``k``'s cam line under roller ``j``'s cam force (an
annulus: a function of the angle between them). Where roller ``k`` is not
loadable its row and column are zero.

The coupled equilibrium ``h_k = a_k tau + g_k + n_k . u - d_k``, ``d = C F``:
Newton on ``d``. Each step solves the drive with the gaps ``g - d``
(:meth:`~corr_cad.mechanics.drive.drive.DriveSolver.solve_contacts`, its own
solve) and corrects ``d`` with the linearised drive's response
``dF/dd = -(K - K B J^-1 A^T K)`` (``K`` the rollers' contact stiffnesses,
``B``, ``A`` the overlaps' and the balances' columns of the crank rotation and
of each floating cam's centre, ``J = A^T K B`` plus the needles' stiffness):
exact where no roller changes between loaded and free, so a few steps reach
round-off.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from corr_cad.geometry.design import GearDesign
from corr_cad.mechanics.drive.drive_numerics import _forces_of, roller_directions
from corr_cad.mechanics.drive.drive_restart import replace_positions
from corr_cad.mechanics.row.solver_geometry import RollerGeometry

__all__ = [
    "BodyTables",
    "Influence",
    "influence_inputs",
    "influence_matrices",
    "coupled_solve",
    "BODIES_RTOL",
]

#: The body approaches' relative residual ``|d - C F| / max |C F|`` the coupled solve reaches.
BODIES_RTOL = 1e-12


@dataclass(frozen=True)
class BodyTables:
    """Influence tables of both bodies (see the module's docstring), mm/N.

    ``ring`` (M, M z): one ring; ``frame`` (Mf, R, 2, Mf): one frame plate
    (side 0 = ``+``, 1 = ``-``) at ``frame_radii`` (Mf,), mm; ``nodes``: the
    meshes' node counts (ring, frame, cam); ``mesh_size``: the finest element,
    mm; ``cam`` (Mc,): one cam, the approach at angle ``2 pi m / Mc`` from a unit
    load (None: the cams rigid).
    """

    ring: np.ndarray
    frame: np.ndarray
    frame_radii: np.ndarray
    nodes: tuple[int, ...]
    mesh_size: float
    cam: np.ndarray | None = None


def _bilinear(flat, base, i0, fi, d0, fd, di, dd):
    """Bilinear interpolation in (load index, offset) of a flattened table: corner
    ``(i, d)`` at ``flat[base + i * di + d * dd]``."""
    k = base + i0 * di + d0 * dd
    return (1 - fi) * ((1 - fd) * flat[k] + fd * flat[k + dd]) + fi * (
        (1 - fd) * flat[k + di] + fd * flat[k + di + dd]
    )


def _ring(T: np.ndarray, xa: np.ndarray, xb: np.ndarray) -> np.ndarray:
    """The ring's table at grid coordinates ``xa`` (load), ``xb`` (read), bilinear in
    the load angle and the offset ``xb - xa`` (exact on the offset grid: a roller's own
    term is read at offset 0). ``T`` is re-indexed by (load, offset), the load index
    wrapped once (row ``M`` is row 0 one pitch on) and the offset padded by one."""
    M, Mz = T.shape
    d = np.mod(xb - xa + 0.5 * Mz, Mz) - 0.5 * Mz
    xa = np.mod(xa, M)  # the ring's z-fold symmetry: both shifted by whole pitches
    i0 = np.minimum(np.floor(xa).astype(np.intp), M - 1)
    d0 = np.floor(d).astype(np.intp)
    fi, fd = xa - i0, d - d0
    # By (load i, offset o): U[i, o] = T[i mod M, (i mod M + o) mod Mz], o in [-Mz/2 - 1, Mz/2 + 1].
    half = Mz // 2 + 2
    offs = np.arange(-half, half + 1)
    rows = np.arange(M + 1)
    U = T[rows[:, None] % M, (rows[:, None] % M + offs[None, :]) % Mz]
    return _bilinear(U.ravel(), half, i0, fi, d0, fd, U.shape[1], 1)


def _frame(T, rho, ra, sa, ka, rb, sb, kb):
    """One frame plate's table for loads at radius ``ra``, side ``sa``, slot ``ka`` read at
    ``rb``, ``sb``, ``kb`` (broadcasting arrays); the mirror gives a ``-`` side's load.
    Bilinear in the load radius and the offset of the read radius from it."""
    Mf, R = T.shape[0], T.shape[1]
    m = np.mod(kb - ka, R)
    flip = sa < 0
    m = np.where(flip, np.mod(-m, R), m)
    side = np.where((sb > 0) != flip, 0, 1)
    step = rho[1] - rho[0]
    xa = np.clip((ra - rho[0]) / step, 0.0, Mf - 1.0)
    xb = np.clip((rb - rho[0]) / step, 0.0, Mf - 1.0)
    d = xb - xa
    i0 = np.minimum(np.floor(xa), Mf - 2).astype(np.intp)
    d0 = np.floor(d).astype(np.intp)
    fi, fd = xa - i0, d - d0
    # The read radius padded by one each side (i0 + d0 + 1 lies in [0, Mf]).
    Tp = np.concatenate([T[..., :1], T, T[..., -1:]], axis=-1)  # (Mf, R, 2, Mf + 2)
    W = Mf + 2
    base = (m * 2 + side) * W + 1 + i0 * (R * 2 * W) + i0
    return _bilinear(Tp.ravel(), base, 0, fi, d0, fd, R * 2 * W + 1, 1)


def influence_inputs(
    tables: BodyTables,
    design: GearDesign,
    crank_angles: np.ndarray,
    geometry: tuple[RollerGeometry, RollerGeometry],
    directions: np.ndarray | None = None,
) -> tuple:
    """The compiled kernels' reading of the tables at the positions (P,):
    ``(ring, frame, rho0, step, x, rn, rs, s, cam, xc, on)``
    (:func:`~corr_cad.mechanics.drive.coupling_kernel.influence_kernel`); ``directions``
    (P, 2R, 2): the rollers' from their cams' centres where known (the drive solver's)."""
    z, R = design.tooth_count, design.roller_count
    phi = np.asarray(crank_angles, dtype=float).reshape(-1)
    theta = np.arange(R) * design.slot_pitch_rad
    Mz = tables.ring.shape[1]
    step = 2.0 * np.pi / Mz
    t = np.concatenate(
        [(phi[:, None] + c * np.pi) / z + theta[None, :] for c in (0, 1)], axis=1
    )  # each roller's polar angle on its own ring
    geo = geometry
    rn = np.concatenate([np.where(g.loadable, g.rho_n, 0.0) for g in geo], axis=1)
    rs = np.concatenate([np.where(g.loadable, g.rho_s, 0.0) for g in geo], axis=1)
    s = np.ascontiguousarray(np.concatenate([g.s for g in geo], axis=1))
    x = t / step
    # Each roller's direction from its cam's centre, as an index of the cam's table.
    cam = np.zeros(1) if tables.cam is None else np.ascontiguousarray(tables.cam)
    if tables.cam is None:
        xc = np.zeros(x.shape)
    else:
        n = directions
        if n is None:
            n = np.concatenate([roller_directions(design, g) for g in geo], axis=1)
        xc = np.mod(np.arctan2(n[..., 0], n[..., 1]), 2 * np.pi) * (len(cam) / (2 * np.pi))
    on = np.concatenate([g.loadable for g in geo], axis=1) & (tables.cam is not None)
    rho = tables.frame_radii
    return (
        np.ascontiguousarray(tables.ring),
        np.ascontiguousarray(tables.frame),
        float(rho[0]),
        float(rho[1] - rho[0]),
        x,
        rn,
        rs,
        s,
        cam,
        xc,
        on,
    )


def influence_matrices(
    tables: BodyTables,
    design: GearDesign,
    crank_angles: np.ndarray,
    geometry: tuple[RollerGeometry, RollerGeometry],
    compiled: bool = True,
    columns: np.ndarray | None = None,
) -> np.ndarray:
    """``C`` (P, 2R, 2R), mm/N: roller ``k``'s body approach per newton of roller ``j``'s
    cam force (row A's rollers first), at crank angles (P,). ``compiled``: by the
    compiled loop (:mod:`~corr_cad.mechanics.drive.coupling_kernel`), else by numpy
    (the same interpolation; the tests hold them equal). ``columns`` (P, 2R) bool, compiled
    only: the loads whose columns are made, the others left 0 (None: all)."""
    R = design.roller_count
    tb = influence_inputs(tables, design, crank_angles, geometry)
    _, _, _, _, x, rn, rs, s, cam, xc, on = tb
    if compiled:
        from corr_cad.mechanics.drive.coupling_kernel import influence_kernel

        Ct = np.empty((len(x), 2 * R, 2 * R))
        cols = np.ones(x.shape, dtype=bool) if columns is None else columns
        influence_kernel(tb, np.asarray(cols, dtype=bool), Ct)
        return np.ascontiguousarray(np.transpose(Ct, (0, 2, 1)))
    phi = np.asarray(crank_angles, dtype=float).reshape(-1)
    slot = np.concatenate([np.arange(R), np.arange(R)])
    row = np.repeat([0, 1], R)
    same = row[:, None] == row[None, :]
    C = np.zeros((len(phi), 2 * R, 2 * R))
    for sl in (slice(0, R), slice(R, 2 * R)):  # each row's own ring: [p, k (read), j (load)]
        ring = _ring(tables.ring, x[:, None, sl], x[:, sl, None])
        C[:, sl, sl] = rn[:, sl, None] * rn[:, None, sl] * ring
    sg = np.sign(rs)
    fr = _frame(
        tables.frame,
        tables.frame_radii,
        s[:, None, :],
        sg[:, None, :],
        slot[None, None, :],
        s[:, :, None],
        sg[:, :, None],
        slot[None, :, None],
    )
    share = np.where(same, 0.5, 0.25)
    C += share * np.abs(rs)[:, :, None] * np.abs(rs)[:, None, :] * fr
    if tables.cam is not None:  # each row's own cam, by the angle between the contacts
        Mc = len(cam)
        dc = np.mod(xc[:, :, None] - xc[:, None, :], Mc)
        i0 = np.floor(dc).astype(np.intp)
        f = dc - i0
        G = (1 - f) * cam[i0 % Mc] + f * cam[(i0 + 1) % Mc]
        C += np.where(same & on[:, :, None] & on[:, None, :], G, 0.0)
    return C


def _response(solver, tau, F, u, geo) -> np.ndarray:
    """``dF/dd`` of the drive at its solution (module docstring) as ``(k (P, N),
    K B (P, N, m), X (P, m, N))``: ``dF/dd = -(diag(k) - K B X)``, ``m`` = 1 (cams
    fixed) or 5 (the crank and both cams' centres)."""
    loadable = geo.loadable
    a_c = np.where(loadable, geo.advance, 0.0)
    a_m = np.where(loadable, geo.arm, 0.0)
    h0 = np.where(loadable, geo.gap, -1e300)
    n, R = solver.n, solver.R
    P, N = F.shape
    uu = np.concatenate([np.repeat(u[0][:, None, :], R, 1), np.repeat(u[1][:, None, :], R, 1)], 1)
    h = a_c * tau[:, None] + h0 + np.sum(n * uu, axis=-1)
    _, k = _forces_of(solver.comp, h)
    k = np.where(F > 0, k, 0.0)
    floating = solver.bearings[0] is not None
    ncol = 5 if floating else 1
    B = np.zeros((P, N, ncol))
    B[:, :, 0] = a_c
    A = np.zeros((P, N, ncol))
    A[:, :, 0] = a_m
    if floating:
        for c in (0, 1):
            sl = slice(c * R, (c + 1) * R)
            B[:, sl, 1 + 2 * c : 3 + 2 * c] = n[:, sl]
            A[:, sl, 1 + 2 * c : 3 + 2 * c] = n[:, sl]
    KB = k[:, :, None] * B
    J = np.einsum("pni,pnj->pij", A, KB)
    if floating:
        for c, b in enumerate(solver.bearings):
            _, kq = b.loads(u[c])
            e = b.directions()
            J[:, 1 + 2 * c : 3 + 2 * c, 1 + 2 * c : 3 + 2 * c] += np.einsum(
                "pj,jx,jy->pxy", kq, e, e
            )
    tr = np.trace(J, axis1=1, axis2=2)
    J += (1e-12 * tr + 1e-300)[:, None, None] * np.eye(ncol)
    KA = k[:, :, None] * A
    X = np.linalg.solve(J, np.transpose(KA, (0, 2, 1)))  # (P, ncol, N)
    return k, KB, X  # dF/dd = -(diag(k) - KB X): a diagonal less a rank-ncol term


def _take(geo: RollerGeometry, idx: np.ndarray) -> RollerGeometry:
    """The positions ``idx`` of a roller geometry."""
    return replace(
        geo,
        **{
            f.name: getattr(geo, f.name)[idx]
            for f in fields(geo)
            if isinstance(getattr(geo, f.name), np.ndarray) and getattr(geo, f.name).ndim == 2
        },
    )


#: Influence coefficients held at once: positions are coupled a block at a time (4M
#: doubles, 32 MB; the prototype's 1,800 distinct positions of 52 rollers in two blocks).
BLOCK_ENTRIES = 1 << 22


class Influence:
    """The influence matrices ``C`` of a drive solver's positions
    (:func:`influence_matrices`), made once where they fit in :data:`BLOCK_ENTRIES`,
    else a block of positions at a time; ``influence[p]`` is position ``p``'s (N, N)."""

    def __init__(self, tables: BodyTables, design: GearDesign, crank_angles, geometry):
        self.tables, self.design, self.geometry = tables, design, geometry
        self.angles = np.asarray(crank_angles, dtype=float).reshape(-1)
        N = 2 * design.roller_count
        self.block = max(1, BLOCK_ENTRIES // (N * N))
        self._whole, self._kept, self._samples = len(self.angles) <= self.block, None, 1

    @property
    def _all(self) -> np.ndarray | None:
        """Every position's ``C`` where they fit in one block (made at the first use:
        the Newton on the overlaps reads its columns from the tables), else None."""
        if self._whole and self._kept is None:
            P = len(self.angles) // self._samples  # samples' stacks share theirs: made once
            self._kept = np.tile(self._make(np.arange(P)), (self._samples, 1, 1))
        return self._kept

    @classmethod
    def repeated(cls, tables: BodyTables, design: GearDesign, crank_angles, geometry, n: int):
        """The influence of ``n`` samples stacked sample-major over the crank angles (P,)
        (``geometry``: their stacked rows, (n P, R) each) whose geometries differ in the
        gaps and curvatures only: ``C`` depends on neither, so the first sample's matrices
        serve every sample (made once, not ``n`` times)."""
        P = len(np.asarray(crank_angles, dtype=float).reshape(-1))
        out = cls.__new__(cls)
        out.tables, out.design, out.geometry = tables, design, geometry
        out.angles = np.tile(np.asarray(crank_angles, dtype=float).reshape(-1), n)
        N = 2 * design.roller_count
        out.block = max(1, BLOCK_ENTRIES // (N * N))
        out._whole, out._kept, out._samples = n * P <= out.block, None, n
        return out

    def _make(self, idx: np.ndarray, columns: np.ndarray | None = None) -> np.ndarray:
        geo = tuple(_take(g, idx) for g in self.geometry)
        return influence_matrices(self.tables, self.design, self.angles[idx], geo, columns=columns)

    def inputs(self, idx: np.ndarray, directions: np.ndarray | None = None) -> tuple:
        """The tables as read at the positions ``idx`` (:func:`influence_inputs`; the
        rollers' ``directions`` at them where known)."""
        every = idx.size == len(self.angles) and np.array_equal(idx, np.arange(idx.size))
        geo = self.geometry if every else tuple(_take(g, idx) for g in self.geometry)
        return influence_inputs(self.tables, self.design, self.angles[idx], geo, directions)

    def matrices(self, idx: np.ndarray, columns: np.ndarray | None = None) -> np.ndarray:
        """``C`` (len(idx), N, N) of the positions ``idx`` (``columns`` (len(idx), N):
        only those loads' columns, the others 0, where not made once for all)."""
        if self._all is not None:
            return self._all[idx]
        return self._make(idx, columns)

    def part_tables(self) -> dict[str, BodyTables]:
        """Each body's tables alone (the others' zero): ``ring_body``, ``frame`` and, where
        the cams are elastic, ``cam_body``. ``C`` is linear in the tables, so the parts'
        matrices add up to ``C``."""
        t = self.tables
        ring0, frame0 = np.zeros_like(t.ring), np.zeros_like(t.frame)
        out = {
            "ring_body": replace(t, frame=frame0, cam=None),
            "frame": replace(t, ring=ring0, cam=None),
        }
        if t.cam is not None:
            out["cam_body"] = replace(t, ring=ring0, frame=frame0)
        return out

    def work(self, F: np.ndarray) -> dict[str, np.ndarray]:
        """Each body's work ``F . C_body F`` (P,) N*mm of the roller forces ``F`` (P, N)."""
        parts = self.part_tables()
        out = {name: np.zeros(len(F)) for name in parts}
        for first in range(0, len(self.angles), self.block):
            idx = np.arange(first, min(len(self.angles), first + self.block))
            geo = tuple(_take(g, idx) for g in self.geometry)
            for name, t in parts.items():
                C = influence_matrices(t, self.design, self.angles[idx], geo)
                out[name][idx] = np.einsum("pk,pkj,pj->p", F[idx], C, F[idx])
        return out

    def __getitem__(self, p):
        idx = np.arange(len(self.angles))[p]
        C = self.matrices(np.atleast_1d(idx))
        return C if np.ndim(idx) else C[0]


def _newton_block(solver, target, influence, blk, base, start, d, chain=None):
    """:func:`~corr_cad.mechanics.drive.coupling_newton.overlap_newton` on the positions
    ``blk`` of the drive ``base = (geometry, contact law, directions)`` from the drive's
    solution ``start = (tau, F, u)`` at the approaches ``d`` (``chain``: its positions'
    order and sources, as there): ``(tau, F, d, rel, ok, iterations, u, Q)``."""
    geo0, comp0, n0 = base
    tau, _, u = start
    whole = blk.size == geo0.gap.shape[0]
    geo = geo0 if whole else _take(geo0, blk)
    comp = comp0 if whole else comp0.take(blk)
    floating = solver.bearings[0] is not None
    cams = (n0[blk], u, solver.bearings) if floating else None
    from corr_cad.mechanics.drive.coupling_newton import overlap_newton  # numba: when run

    return overlap_newton(
        comp, geo, influence.inputs(blk, n0[blk]), target, tau, d, solver.rtol, BODIES_RTOL,
        tight=1e-2 if solver.crank is not None else 1.0,  # the crank iterates on F
        cams=cams, chain=chain,
    )  # fmt: skip


def _chain(solver, idx: np.ndarray):
    """The positions ``idx``'s order by their phase in the drive's period (a slot pitch
    of crank angle), each one's neighbour before it and the slots between them:
    ``(order, src, shift)`` (len(idx),) each for
    :func:`~corr_cad.mechanics.drive.coupling_newton.overlap_newton`. Roller ``k`` at
    ``phi + 2 pi / R`` is where roller ``k - 1`` was at ``phi``."""
    R = solver.R
    turns = solver.crank_angles[idx] * R / (2.0 * np.pi)
    slots = np.floor(turns)
    order = np.argsort(turns - slots, kind="stable")
    src = np.full(len(idx), -1)
    src[order[1:]] = order[:-1]
    shift = np.zeros(len(idx), dtype=np.int64)
    shift[order[1:]] = (slots[order[1:]] - slots[order[:-1]]).astype(np.int64) % R
    return order, src, shift


def _one_needle_count(solver) -> bool:
    """The cams fixed, or both on needle bearings of one needle count (the compiled
    Newton's)."""
    a, b = solver.bearings
    return a is None or a.needles == b.needles


def coupled_solve(
    solver,
    target: float,
    influence: Influence,
    max_iter: int = 50,
    start: np.ndarray | None = None,
    direct: bool = True,
):
    """The drive's solution ``(tau, F, u, Q, rel, iterations)`` with the bodies'
    ``influence`` (module docstring); ``rel`` includes the body residual. A block of
    positions at a time; each Newton step solves again only the positions not yet
    converged. ``start``: the bodies' approaches ``d`` (P, N) the Newton starts from
    (zero: the rigid bodies' drive); the converged ``d`` is left in ``influence.last_d``.
    ``direct``: the positions are first solved by one Newton on the overlaps
    (:mod:`~corr_cad.mechanics.drive.coupling_newton`); those it does not settle, by the
    Newton on ``d``."""
    geo0, comp0, n0 = solver.geo_joined, solver.comp, solver.n
    P, N = geo0.gap.shape
    eye = np.eye(N)
    its = 0
    body_rel = np.zeros(P)
    out: list = []
    d_all = np.zeros((P, N)) if start is None or start.shape != (P, N) else start.copy()

    def use(idx, d):
        sub = idx.size < P
        solver.geo_joined = replace(_take(geo0, idx) if sub else geo0, gap=geo0.gap[idx] - d)
        solver.comp = comp0.take(idx) if sub else comp0
        solver.n = n0[idx]

    def contacts(idx, d, warm=False):
        use(idx, d)
        if not warm or out[3] is None:
            sol = solver.solve_contacts(target)
        else:  # the bearing Newton from the last step's crank rotation and cam centres
            solver._u_start = out[2][:, idx]
            try:
                sol = solver._with_bearings(target, out[0][idx], out[1][idx], 0)
            finally:
                solver._u_start = None
            bad = np.flatnonzero(~(sol[4] <= max(solver.rtol, 1e-9)))
            if bad.size:  # those from the drive's own start
                sol = list(sol)
                replace_positions(sol, contacts(idx[bad], d[bad]), bad, np.ones(bad.size, bool))
                use(idx, d)
        if not out:
            out.extend([np.zeros(P), np.zeros((P, N)), np.zeros((2, P, 2)), None, np.zeros(P)])
            if sol[3] is not None:
                out[3] = [np.zeros((P, q.shape[1])) for q in sol[3]]
        tau, F, u, Qs, rel, _ = sol
        out[0][idx], out[1][idx], out[2][:, idx], out[4][idx] = tau, F, u, rel
        if Qs is not None:
            for c in (0, 1):
                out[3][c][idx] = Qs[c]
        return sol

    def accept(idx, got, ok, d):
        done = idx[ok]
        out[0][done], out[1][done], out[4][done] = got[0][ok], got[1][ok], got[3][ok]
        if got[7] is not None:
            out[2][:, done] = got[6][:, ok]
            for c in (0, 1):
                out[3][c][done] = got[7][c][ok]
        body_rel[done] = 0.0
        d[ok] = got[2][ok]

    base = (geo0, comp0, n0)
    direct = direct and _one_needle_count(solver)
    pending = np.arange(P)
    try:
        if direct and start is None:
            # In the order of the positions' phase, each from its neighbour's solution;
            # the first from the drive's own solve.
            order, src, shift = _chain(solver, pending)
            first = order[:1]
            tau, F, u, _, _, it = contacts(first, d_all[first])
            its += it
            given = np.zeros(P, dtype=bool)
            given[first] = True
            t0, u0 = np.zeros(P), np.zeros((2, P, 2))
            t0[first], u0[:, first] = tau, u
            got = _newton_block(
                solver, target, influence, pending, base, (t0, None, u0), d_all,
                chain=(order, src, shift, given),
            )  # fmt: skip
            its += got[5]
            accept(pending, got, got[4], d_all)
            pending = np.flatnonzero(~got[4])
        for first in range(0, pending.size, influence.block):
            blk = pending[first : first + influence.block]
            d = d_all[blk]
            rest = np.arange(len(blk))  # the block's positions left to the Newton on d
            if direct:
                tau, F, u, _, _, it = contacts(blk, d)
                its += it
                got = _newton_block(solver, target, influence, blk, base, (tau, F, u), d)
                its += got[5]
                accept(blk, got, got[4], d)
                rest = np.flatnonzero(~got[4])
            if rest.size:
                C = influence.matrices(blk[rest])
                at = np.arange(len(rest))  # the positions still iterating, in rest
            else:
                at = rest
            for step in range(max_iter if at.size else 0):
                idx = blk[rest[at]]
                tau, F, u, Qs, rel, it = contacts(idx, d[rest[at]], warm=step > 0)
                its += it
                Ci = C[at]
                cf = (Ci @ F[:, :, None])[:, :, 0]
                r = d[rest[at]] - cf
                top = np.max(np.abs(cf), axis=1)
                rel_i = np.where(top > 0, np.max(np.abs(r), axis=1) / (top + 1e-300), 0.0)
                body_rel[idx] = rel_i
                todo = rel_i > BODIES_RTOL
                if not np.any(todo):
                    break
                k, KB, X = _response(solver, tau, F, u, solver.geo_joined)
                t = np.flatnonzero(todo)
                Ct = Ci[t]
                # I - C dF/dd = I + C diag(k) - (C K B) X: no N^3 product.
                Jd = eye + Ct * k[t, None, :] - (Ct @ KB[t]) @ X[t]
                d[rest[at[t]]] -= np.linalg.solve(Jd, r[t, :, None])[:, :, 0]
                at = at[t]
            d_all[blk] = d
    finally:
        solver.geo_joined, solver.comp, solver.n = geo0, comp0, n0
    influence.last_d = d_all
    tau, F, u, Qs, rel = out
    return tau, F, u, Qs, np.maximum(rel, np.where(body_rel > BODIES_RTOL, body_rel, 0.0)), its
