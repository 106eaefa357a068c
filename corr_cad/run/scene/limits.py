"""The structural limits of a scene, checked at load time: DXF vertices and mesh triangles.

Vertex counts come from the exact curves' curvature: a chord of length
``l`` on a circle of radius ``R`` misses it by ``l^2 / (8 R)``, so a polyline
within ``tol`` needs ``integral of sqrt(kappa / (8 tol)) ds`` segments.
The budget (memory, files, time) is :mod:`corr_cad.run.budget.resources`. Pure numpy.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from corr_cad.errors import SceneError

__all__ = [
    "unique_angle_tags",
    "MAX_PROFILE_VERTICES",
    "MAX_MESH_TRIANGLES",
    "polyline_segments",
    "profile_vertices",
    "modified_ratio",
    "mesh_triangles",
    "check_structure",
    "SceneSize",
    "scene_size",
    "tolerance_floors",
    "round_up",
]

#: Most vertices (polyline/arcs) or control points (spline) of one DXF profile:
#: the approximator's own budget (``sampling._MAX_VERTICES``, a test keeps the
#: two equal), beyond which it cannot reach the tolerance.
MAX_PROFILE_VERTICES = 200_000
#: Most triangles of one mesh file (an STL of 5e6 triangles is 250 MB).
MAX_MESH_TRIANGLES = 5_000_000
#: The prototype's assembly_000deg.stl at chord_tolerance 1e-3 has 174 364
#: triangles, the extruded-polygon count below gives 119 787: scale by 1.5.
MESH_CALIBRATION = 1.5


def _locus(design, per_tooth: int = 400) -> tuple[np.ndarray, np.ndarray]:
    """Roller-centre locus and the working profile (outer offset by r), (n, 2) each."""
    z, e, r = design.tooth_count, design.eccentricity, design.roller_radius
    L = design.cam_radius + r
    t = np.linspace(0.0, 2.0 * np.pi, per_tooth * z, endpoint=False)
    psi = z * t
    s = e * np.cos(psi) + np.sqrt(L * L - (e * np.sin(psi)) ** 2)
    p = np.stack([s * np.sin(t), s * np.cos(t)], axis=1)
    d = np.roll(p, -1, axis=0) - np.roll(p, 1, axis=0)
    tang = d / np.linalg.norm(d, axis=1)[:, None]
    # The curve runs clockwise (x = s sin t, y = s cos t): outward is the tangent turned left.
    normal = np.stack([-tang[:, 1], tang[:, 0]], axis=1)
    if np.sum(normal * p) < 0:
        normal = -normal
    return p, p + r * normal


def polyline_segments(points: np.ndarray, tol: float) -> float:
    """Segments a polyline within ``tol`` needs along the closed curve ``points`` (n, 2)."""
    a = np.roll(points, 1, axis=0)
    c = np.roll(points, -1, axis=0)
    ab = np.linalg.norm(points - a, axis=1)
    bc = np.linalg.norm(c - points, axis=1)
    ac = np.linalg.norm(c - a, axis=1)
    cross = np.abs((points - a)[:, 0] * (c - a)[:, 1] - (points - a)[:, 1] * (c - a)[:, 0])
    kappa = 2.0 * cross / np.maximum(ab * bc * ac, 1e-300)  # circumscribed circle
    ds = 0.5 * (ab + bc)
    return float(np.sum(np.sqrt(kappa / (8.0 * tol)) * ds)) + 1.0


@functools.lru_cache(maxsize=16)
def _curvature_integrals(design) -> tuple[float, float]:
    """``polyline_segments - 1`` of the working profile and of the locus at tol = 1e-3."""
    locus, work = _locus(design)
    return polyline_segments(work, 1e-3) - 1.0, polyline_segments(locus, 1e-3) - 1.0


def _circle(radius: float, tol: float) -> float:
    """Segments of a polygon within ``tol`` of a circle of ``radius``.

    ``pi / acos(1 - tol/R)``, written as ``pi / (2 asin(sqrt(tol / 2R)))``:
    the same number, but finite for every tolerance (``1 - 1e-300`` is 1.0,
    and ``acos(1)`` is 0); ``inf`` where ``tol / 2R`` underflows to 0 (5e-324).
    """
    if tol >= radius:
        return 8.0
    half = math.asin(math.sqrt(tol / (2.0 * radius)))  # 0 where tol / 2R underflows
    return max(8.0, math.pi / (2.0 * half)) if half > 0.0 else math.inf


def _power(x: float, ratio: float, exponent: float) -> float:
    """``x * ratio ** exponent`` in logarithms: ``inf`` beyond the float range, never an error."""
    if x <= 0:
        return 0.0
    log = math.log(x) + exponent * math.log(ratio)
    return math.exp(log) if log < 700 else math.inf


#: Representation -> exponent of 1/tol in the vertex count and the count at
#: tol = 1e-3 as a multiple of the curvature integral there. Measured on the
#: prototype, working and theoretical profiles, tol = 1e-2, 1e-3, 1e-4
#: (``approximate``): polyline 1300/4500/13650 vertices against an integral
#: of 768/2430/7685 (ratio <= 1.85, exponent 1/2); arcs 800/1400/2800; spline
#: 451/701/1251 control points. The ratios round the worst case up; the
#: node-budget sampler (polyline 800/2525/7775) stays below the estimate.
_REPR = {"polyline": (0.5, 1.9), "arcs": (1.0 / 3.0, 0.6), "spline": (0.25, 0.3)}


def _vertex_law(design, representation: str, modification=None):
    """``tol -> vertices`` of the ring's profile in ``representation``: the closed form
    from the curvature, times :func:`modified_ratio`; the expensive parts (the
    curvature integral, the modified ring's approximation) computed once here."""
    exponent, ratio = _REPR[representation]
    work, locus = _curvature_integrals(design)
    base = ratio * (max(work, locus) + 1.0)
    wave = modified_ratio(design, modification, representation)
    return lambda tol: _power(base, 1e-3 / tol, exponent) * wave


#: The tolerance at which a modified ring is approximated to scale the estimate, mm.
MODIFIED_REFERENCE_TOL = 1e-3


@functools.lru_cache(maxsize=32)
def modified_ratio(design, modification, representation: str) -> float:
    """How many times the nominal ring's vertices the modified ring's approximation has.

    A ``[modification] normal_table`` can wave along every tooth space, and
    each wave takes vertices (a table oscillating tooth by tooth took 9
    times the nominal spline's control points). The ring is approximated
    here as the stage will do it (:func:`~corr_cad.geometry.sampling.approximate`
    of :func:`~corr_cad.geometry.modification.modified_profile`), at
    ``MODIFIED_REFERENCE_TOL``, and its vertex count divided by the nominal
    ring's there (approximated alike); 1 without a table (the equidistant and
    shift families leave the curvature as it is, to first order).
    """
    if modification is None or getattr(modification, "normal_table", None) is None:
        return 1.0
    from corr_cad.geometry.modification import modified_profile
    from corr_cad.geometry.profile import working_profile
    from corr_cad.geometry.sampling import approximate

    tol = MODIFIED_REFERENCE_TOL
    got = approximate(modified_profile(design, modification), representation, tol)
    nominal = approximate(working_profile(design), representation, tol)
    return max(1.0, got.entity_vertex_count / nominal.entity_vertex_count)


def profile_vertices(design, representation: str, tol: float, modification=None) -> float:
    """Vertices (polyline, arcs) or control points (spline) of the ring's DXF profile at ``tol``.

    The closed form from the curvature, times :func:`modified_ratio` for a
    ring with a ``[modification] normal_table``.
    """
    return _vertex_law(design, representation, modification)(tol)


def _mesh_law(design, modification=None):
    """``chord -> (assembly, part) triangles``, the ring's curvature and waves computed once."""
    work, _ = _curvature_integrals(design)
    R = design.roller_count
    wave = modified_ratio(design, modification, "polyline")

    def triangles(chord: float) -> tuple[float, float]:
        ring = (
            wave * _power(work, 1e-3 / chord, 0.5) + 1.0 + _circle(design.ring_outer_radius, chord)
        )
        cam = _circle(design.cam_radius, chord) + _circle(design.cam_bore_radius, chord)
        roller = _circle(design.roller_radius, chord)
        frame = (
            _circle(design.frame_inner_radius, chord)
            + _circle(design.frame_outer_radius, chord)
            + R * roller
        )
        # An extruded polygon of V vertices: 2 caps of V - 2 triangles, 2V on the side.
        asm = MESH_CALIBRATION * 4.0 * (ring + 2 * cam + 2 * R * roller + 2 * frame)
        parts = MESH_CALIBRATION * 4.0 * (ring + cam + roller + frame)
        return asm, parts

    return triangles


def mesh_triangles(design, chord: float, modification=None) -> tuple[float, float]:
    """Triangles of the assembly mesh and of the four part meshes at ``chord``.

    The ring's outline follows a modification's waves as its polyline does
    (:func:`modified_ratio`).
    """
    return _mesh_law(design, modification)(chord)


#: Formats for which the solids are meshed (and the triangle limit applies);
#: ``interference`` only with a mesh method (the exact clearance meshes nothing).
_MESHED = {"stl", "3mf", "glb", "ply", "step"}


def _meshes(scene) -> bool:
    """Whether the run meshes the solids (and the triangle limit applies)."""
    f = set(scene.formats)
    mesh_interference = "interference" in f and scene.interference_method != "exact"
    return bool(_MESHED & f) or mesh_interference


@dataclass(frozen=True)
class SceneSize:
    """What a scene's run will build, computed once on the way in (:func:`scene_size`).

    The structural limits (:func:`check_structure`) and the resource
    estimate (:func:`corr_cad.run.budget.resources.estimate`) both read it.
    """

    #: Vertices or control points of the ring's profile in ``[export]
    #: representation`` at ``tolerance`` (whether or not a DXF is written: the
    #: wire-EDM and CMM estimates read it too).
    profile_vertices: float
    #: Control points of the ring's spline at ``chord_tolerance`` (the STEP ring); 0 without STEP.
    spline_points: float
    #: Triangles of the assembly mesh and of the part meshes; 0 where nothing is meshed.
    mesh_triangles: float
    part_triangles: float
    #: :func:`tolerance_floors`: ``(key, value, floor, why)`` of each tolerance the scene uses.
    floors: tuple


def _size_key(scene) -> tuple:
    """What a :class:`SceneSize` depends on (a scene is frozen: this guards a copy made by hand)."""
    return (
        scene.design,
        tuple(scene.formats),
        scene.representation,
        scene.tolerance,
        scene.chord_tolerance,
        scene.interference_method,
        id(scene.modification),
        scene.measured_profile is None,
    )


def scene_size(scene) -> SceneSize:
    """The scene's :class:`SceneSize`, computed at the first call and kept on the scene."""
    key = _size_key(scene)
    kept = getattr(scene, "_corr_cad_size", None)
    if kept is not None and kept[0] == key:
        return kept[1]
    d, mod, f = scene.design, scene.modification, set(scene.formats)
    floors = tuple(tolerance_floors(scene))
    tri = parts = 0.0
    if _meshes(scene):
        tri, parts = mesh_triangles(d, scene.chord_tolerance, mod)
    size = SceneSize(
        profile_vertices=profile_vertices(d, scene.representation, scene.tolerance, mod),
        spline_points=profile_vertices(d, "spline", scene.chord_tolerance, mod)
        if "step" in f
        else 0.0,
        mesh_triangles=tri,
        part_triangles=parts,
        floors=floors,
    )
    try:  # a frozen dataclass: not a field, so dataclasses.replace() starts afresh
        object.__setattr__(scene, "_corr_cad_size", (key, size))
    except (AttributeError, TypeError):  # pragma: no cover - an object with __slots__
        pass
    return size


def check_structure(scene) -> tuple[float, float]:
    """Refuse a tolerance finer than the design can honour (:func:`tolerance_floors`),
    which covers a DXF profile beyond ``MAX_PROFILE_VERTICES`` and a mesh beyond
    ``MAX_MESH_TRIANGLES``; the two counts (0 where not made).

    Reads :func:`scene_size`: the check is made once per scene, however often it is called.
    """
    size = scene_size(scene)
    _check_tolerances(size.floors)
    verts = size.profile_vertices if "dxf" in scene.formats else 0.0
    return verts, size.mesh_triangles


#: The finest tolerance accepted, as a fraction of the largest coordinate it
#: applies to. float64 resolves about 1e-16 of a coordinate; the measured
#: deviation of an approximation is noise from a few hundred ulps on (the
#: prototype's 45 mm gear profile: a spline met 3e-13 mm but not 1e-13 mm).
#: 1e-12 keeps a margin of ten and more over that noise.
RESOLUTION = 1e-12
#: Largest ``tolerance`` / ``chord_tolerance`` (the scene schema's bound), mm.
MAX_TOLERANCE = 10.0


def _smallest(need, limit: float, lo: float, hi: float = MAX_TOLERANCE) -> float:
    """The smallest ``x`` in ``[lo, hi]`` with ``need(x) <= limit``, to 1 % (``need`` falls)."""
    if need(lo) <= limit:
        return lo
    if need(hi) > limit:
        return math.inf
    while hi / lo > 1.01:  # bisection of the logarithm: 60 steps from 1e-300 to 10
        mid = math.sqrt(lo) * math.sqrt(hi)
        if need(mid) <= limit:
            hi = mid
        else:
            lo = mid
    return hi


def tolerance_floors(scene) -> list[tuple[str, float, float, list[str]]]:
    """``(key, value, smallest value that works, why)`` for each tolerance the scene uses.

    The smallest value is the larger of the float resolution (:data:`RESOLUTION`
    of the largest coordinate) and what the vertex or triangle budget allows
    (:data:`MAX_PROFILE_VERTICES` for every DXF profile and the wire-EDM
    path, :data:`MAX_MESH_TRIANGLES` for the meshes), for this design.
    ``why`` says which of them ``value`` misses (empty when it is fine).
    """
    d = scene.design
    f = set(scene.formats)
    out = []
    profile = d.link_length + d.roller_radius + d.eccentricity
    uses = []  # (representation, share of the tolerance it is held to, what)
    mod = scene.modification
    if "dxf" in f:
        what = f"a {scene.representation} DXF profile" + (" (the modified one)" if mod else "")
        uses.append((scene.representation, 1.0, what))
        if scene.measured_profile is not None:
            uses.append(("polyline", 1.0, "measured_profile.dxf's polyline"))
    if "edm" in f:
        uses.append(("arcs", 0.7, "the wire-EDM path (arcs to 0.7 of it)"))
    budgets = []
    for rep, share, what in uses:
        need = functools.partial(_share, _vertex_law(d, rep, mod), share)
        budgets.append((need, MAX_PROFILE_VERTICES, what, "vertices"))
    if uses:
        out.append(_floor(scene.tolerance, "tolerance", profile, "profile", budgets))
    if _meshes(scene):
        size = max(d.ring_outer_radius, d.frame_outer_radius, profile)
        law = _mesh_law(d, mod)
        budget = [
            (lambda chord: law(chord)[0], MAX_MESH_TRIANGLES, "the assembly mesh", "triangles")
        ]
        out.append(_floor(scene.chord_tolerance, "chord_tolerance", size, "part", budget))
    return out


def _share(law, share: float, tol: float) -> float:
    return law(share * tol)


def _floor(value: float, key: str, size: float, what_size: str, budgets) -> tuple:
    floor = RESOLUTION * size
    why = []
    if value < floor:
        why.append(f"float64 cannot resolve below 1e-12 of the {size:.4g} mm {what_size}")
    for need, limit, what, unit in budgets:
        low = _smallest(need, limit, RESOLUTION * size)
        floor = max(floor, low)
        if value < low:
            at = f"below {low:.2g} mm" if math.isfinite(low) else "at any tolerance"
            why.append(f"{what} would need more than {limit:g} {unit} {at}")
    return key, value, floor, why


def _check_tolerances(floors) -> None:
    for key, value, floor, why in floors:
        if not why:
            continue
        ok = round_up(floor)
        if not ok <= MAX_TOLERANCE:
            raise SceneError(
                f"[export] {key} = {value:g}: no value up to {MAX_TOLERANCE:g} mm works for "
                f"this design ({'; '.join(why)})"
            )
        raise SceneError(
            f"[export] {key} = {value:g}: too fine for this design: {'; '.join(why)}; "
            f"allowed range here is [{ok:g}, {MAX_TOLERANCE:g}] mm; {key} = {ok:g} would work"
        )


def round_up(x: float) -> float:
    """``x`` rounded up to two significant digits (a value to suggest)."""
    if x <= 0:
        return x
    q = 10 ** (math.floor(math.log10(x)) - 1)
    return math.ceil(x / q) * q


def unique_angle_tags(angles: list[float]) -> None:
    """Two assembly angles must not write the same file name."""
    from corr_cad.export.files import angle_tag

    seen: dict[str, float] = {}
    for a in angles:
        tag = angle_tag(a)
        if tag in seen:
            raise SceneError(
                f"[export] assembly_angles_deg: {seen[tag]:g} and {a:g} both write "
                f"assembly_{tag}.*; angles must differ by at least 0.001 deg"
            )
        seen[tag] = a
