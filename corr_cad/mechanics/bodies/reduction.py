"""The gear ring, the slotted frame and the cams reduced to influence tables (once per design).

Each body is a plane-stress finite-element model
(:class:`~corr_cad.mechanics.bodies.plane.PlaneBody`) of the outline the tool
exports (:func:`corr_cad.geometry.parts.part_outlines`), in the design's
material:

* **The gear ring** (thickness: the face width), held on its outer edge all
  round (a ring pressed into a rigid housing bore). A roller whose centre
  sits at polar angle ``t`` of the ring (kinematics' convention) presses it
  at the working profile's point ``P(t) + r n(t)`` along the locus normal
  ``n(t)``. Loads at ``M`` angles over one tooth pitch are read at ``M z``
  angles all round: ``ring[i, m]`` (mm/N) is the displacement along ``n``
  at angle ``m`` under a unit load at angle ``i``; the ring's ``z``-fold
  symmetry gives every other pair.
* **The slotted frame** (one plate, thickness ``frame_thickness``), held on
  its inner rim (the output flange). A roller at radius ``rho`` presses the
  flank of its slot on side ``sigma = +-1`` (along ``sigma u_t``). Loads on
  slot 0's ``+`` flank at ``Mf`` radii over the roller's travel are read at
  every slot, both flanks, the same radii: ``frame[i, m, side, l]`` (mm/N);
  the frame's ``R``-fold symmetry and its mirror symmetry give every other
  pair.

A load is Hertz's pressure over ``+-b`` of the boundary; each displacement is
read ``depth`` below the surface along the force (the contact law covers the
indentation above it).

* **Each cam** (thickness: the face width), an annulus of the drawn outer and
  bore radii about its own centre (the cam on its eccentric), held at its
  bore: one load, read all round (the table by the angle from the load).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from scipy.spatial import cKDTree

from corr_cad.geometry import kinematics as kin
from corr_cad.geometry.design import SLOT_END_CLEARANCE, GearDesign
from corr_cad.geometry.parts import PartOutline
from corr_cad.mechanics.bodies.mesh import mesh_region
from corr_cad.mechanics.bodies.plane import PlaneBody, patch_nodes
from corr_cad.mechanics.drive.coupling import BodyTables

__all__ = [
    "MeshSpec",
    "BodyTables",
    "reduce_bodies",
    "ring_model",
    "frame_model",
    "ring_table",
    "frame_table",
]


@dataclass(frozen=True)
class MeshSpec:
    """Mesh and load sizes relative to the roller radius ``r``.

    ``fine``: element size at the loaded boundary (``r / 8`` = 1 mm on the
    prototype); ``grade``: growth of the size with the distance from it;
    ``coarse``: the largest size (``r / 2``); ``half_width``: the pressure's
    half-width ``b`` (``r / 16``); ``depth``: the reading depth (``3 r / 8``);
    ``spacing``: the load and reading spacing along the boundary (``r / 8``).
    """

    fine: float = 1.0 / 8.0
    grade: float = 0.4
    coarse: float = 0.5
    half_width: float = 1.0 / 16.0
    depth: float = 3.0 / 8.0
    spacing: float = 1.0 / 8.0

    def refined(self, factor: float) -> MeshSpec:
        """The same loads on a mesh ``factor`` times finer."""
        return MeshSpec(
            self.fine / factor,
            self.grade,
            self.coarse / factor,
            self.half_width,
            self.depth,
            self.spacing,
        )


def _size(tree: cKDTree, fine: float, grade: float, coarse: float):
    reach = (coarse - fine) / grade  # beyond it the size is the coarse one

    def h(x: np.ndarray) -> np.ndarray:
        d, _ = tree.query(np.asarray(x, dtype=float), distance_upper_bound=reach)
        return np.clip(fine + grade * d, fine, coarse)

    return h


def _densify(poly: np.ndarray, step: float) -> np.ndarray:
    a = np.asarray(poly, dtype=float)
    b = np.roll(a, -1, axis=0)
    n = np.maximum(np.ceil(np.linalg.norm(b - a, axis=1) / step).astype(int), 1)
    return np.vstack(
        [a[i] + (b[i] - a[i]) * (np.arange(n[i])[:, None] / n[i]) for i in range(len(a))]
    )


def _on_boundary(line: shapely.LinearRing, pts: np.ndarray, b: float, s: np.ndarray) -> np.ndarray:
    """Points ``b s`` (arc length) either side of each point's projection on ``line``."""
    length = line.length
    s0 = shapely.line_locate_point(line, shapely.points(pts))
    at = np.mod(s0[:, None] + b * s[None, :], length)
    q = shapely.line_interpolate_point(line, at)
    return shapely.get_coordinates(q).reshape(len(pts), len(s), 2)


def ring_model(design: GearDesign, ring: PartOutline, spec: MeshSpec) -> PlaneBody:
    """The ring's finite-element model (held on its outer edge)."""
    r = design.roller_radius
    fine, coarse = spec.fine * r, spec.coarse * r
    profile = ring.holes[0]
    tree = cKDTree(_densify(profile, 0.25 * fine))
    pts, tri, loops = mesh_region(
        ring.outer, [profile], _size(tree, fine, spec.grade, coarse), fine
    )
    E, nu = design.material.young_modulus, design.material.poisson_ratio
    return PlaneBody(pts, tri, loops, 0, E, nu, ring.thickness)


def frame_model(design: GearDesign, frame: PartOutline, spec: MeshSpec) -> PlaneBody:
    """One frame plate's finite-element model (held on its inner rim)."""
    r = design.roller_radius
    fine, coarse = spec.fine * r, spec.coarse * r
    slots = frame.holes[1:]
    tree = cKDTree(np.vstack([_densify(s, 0.25 * fine) for s in slots]))
    pts, tri, loops = mesh_region(
        frame.outer, frame.holes, _size(tree, fine, spec.grade, coarse), fine
    )
    E, nu = design.material.young_modulus, design.material.poisson_ratio
    return PlaneBody(pts, tri, loops, 1, E, nu, frame.thickness)


def ring_table(
    design: GearDesign, ring: PartOutline, spec: MeshSpec, body: PlaneBody | None = None
):
    """``(table (M, M z), body)`` of the ring (module docstring)."""
    z, e, L, r = design.tooth_count, design.eccentricity, design.link_length, design.roller_radius
    body = body or ring_model(design, ring, spec)
    pitch = 2.0 * np.pi / z
    # Samples along the profile no farther apart than spacing * r (at the tooth space).
    M = int(np.ceil(pitch * (L + e + r) / (spec.spacing * r)))
    t = np.arange(M * z) * pitch / M
    centre = kin.locus_points(t, z, e, L)
    n = kin.locus_normals(t, z, e, L)
    contact = centre + r * n
    read = contact + spec.depth * r * n
    line = shapely.LinearRing(ring.holes[0])
    b = spec.half_width * r
    patch = _on_boundary(line, contact[:M], b, patch_nodes()) + 0.1 * b * n[:M, None, :]
    C = body.influence_patches(patch, n[:M], read, n)
    return C.T, body


def frame_table(
    design: GearDesign, frame: PartOutline, spec: MeshSpec, body: PlaneBody | None = None
):
    """``(table (Mf, R, 2, Mf), radii (Mf,), body)`` of one frame plate (module docstring)."""
    R, e, L, r = design.roller_count, design.eccentricity, design.link_length, design.roller_radius
    body = body or frame_model(design, frame, spec)
    reach = e + 0.5 * SLOT_END_CLEARANCE
    Mf = int(np.ceil(2.0 * reach / (spec.spacing * r))) + 1
    rho = np.linspace(L - reach, L + reach, Mf)
    theta = np.arange(R) * design.slot_pitch_rad
    ur, ut = kin.unit_radial(theta), kin.unit_tangential(theta)
    sides = np.array([1.0, -1.0])
    # read[m, side, l]
    off = (r + spec.depth * r) * sides
    read = (
        rho[None, None, :, None] * ur[:, None, None, :]
        + off[None, :, None, None] * ut[:, None, None, :]
    )
    rdir = np.broadcast_to(sides[None, :, None, None] * ut[:, None, None, :], read.shape)
    b = spec.half_width * r
    s = patch_nodes()
    u0, t0 = ur[0], ut[0]
    patch = (
        rho[:, None, None] * u0 + b * s[None, :, None] * u0 + (r + 0.1 * b) * t0
    )  # (Mf, k, 2): slot 0's + flank
    C = body.influence_patches(
        patch, np.broadcast_to(t0, (Mf, 2)), read.reshape(-1, 2), rdir.reshape(-1, 2)
    )
    return C.T.reshape(Mf, R, 2, Mf), rho, body


def cam_table(design: GearDesign, cam: PartOutline, spec: MeshSpec) -> tuple[np.ndarray, int]:
    """``(table (Mc,), nodes)`` of one cam: the approach at angle ``2 pi m / Mc`` from a
    unit load at angle 0. The cam on its eccentric: an annulus of the drawn radii, its
    bore about its own centre and held there (the drawn cam's bore, offset by ``e`` on
    the crank, changes its own term by about 2 %: the manual)."""
    r, Rj = design.roller_radius, design.cam_radius
    fine, coarse = spec.fine * r, spec.coarse * r
    bore = design.cam_bore_radius
    n_b = max(64, int(np.ceil(2 * np.pi * bore / coarse)))
    a = 2 * np.pi * np.arange(n_b) / n_b
    hole = np.stack([bore * np.sin(a), bore * np.cos(a)], axis=1)  # clockwise
    tree = cKDTree(_densify(cam.outer, 0.25 * fine))
    h = _size(tree, fine, spec.grade, coarse)
    pts, tri, loops = mesh_region(cam.outer, [hole], h, fine)
    E, nu = design.material.young_modulus, design.material.poisson_ratio
    body = PlaneBody(pts, tri, loops, 1, E, nu, cam.thickness)
    Mc = int(np.ceil(2 * np.pi * Rj / (spec.spacing * r)))
    ang = 2 * np.pi * np.arange(Mc) / Mc
    u = kin.unit_radial(ang)  # the roller's direction from the cam's centre
    patch = Rj * u[:1]
    C = body.influence(
        patch,
        -u[:1],
        kin.unit_tangential(ang[:1]),
        spec.half_width * r,
        (Rj - spec.depth * r) * u,
        -u,
    )
    return C[:, 0], int(body.mesh.p.shape[1])


def reduce_bodies(
    design: GearDesign, outlines: dict[str, PartOutline], spec: MeshSpec | None = None
) -> BodyTables:
    """Both bodies' influence tables from the part outlines (``ring``, ``frame``)."""
    spec = spec or MeshSpec()
    ring, rbody = ring_table(design, outlines["ring"], spec)
    frame, rho, fbody = frame_table(design, outlines["frame"], spec)
    cam, cam_nodes = cam_table(design, outlines["cam"], spec)
    return BodyTables(
        ring=ring,
        frame=frame,
        frame_radii=rho,
        nodes=(int(rbody.mesh.p.shape[1]), int(fbody.mesh.p.shape[1]), cam_nodes),
        mesh_size=spec.fine * design.roller_radius,
        cam=cam,
    )
