"""The elastic bodies of ``[solver] bodies = "elastic"``: their tables, cached on disk.

The ring's and the frame's influence tables
(:func:`corr_cad.mechanics.bodies.reduction.reduce_bodies`) are computed once
per design from the part outlines the tool exports and kept in the user's
cache folder (never the output folder): ``$CORR_CAD_CACHE_DIR``, else
``$XDG_CACHE_HOME/corr_cad``, else ``~/.cache/corr_cad``; one file
``bodies/<key>.npz`` per design, the key a SHA-256 of everything the tables
depend on (the outlines' points and thickness, the design's kinematics, the
material, the mesh settings and the format's version). A changed geometry
is a new key; an unreadable file is computed again and replaced.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import numpy as np

from corr_cad.mechanics.bodies.reduction import BodyTables, MeshSpec, reduce_bodies

__all__ = [
    "cache_dir",
    "body_key",
    "cached_tables",
    "body_tables",
    "design_tables",
    "bodies_description",
]

#: Bumped whenever the tables' meaning or the FE model changes (a new key for every design).
CACHE_VERSION = 2


def cache_dir() -> Path:
    """The user's cache folder of corr_cad (see the module's docstring)."""
    env = os.environ.get("CORR_CAD_CACHE_DIR")
    if env:
        return Path(env)
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "corr_cad"


def body_key(design, outlines: dict, spec: MeshSpec) -> str:
    """The tables' cache key: a SHA-256 of what they depend on."""
    h = hashlib.sha256()
    meta = {
        "version": CACHE_VERSION,
        "z": design.tooth_count,
        "e": design.eccentricity,
        "L": design.link_length,
        "r": design.roller_radius,
        "R": design.roller_count,
        "E": design.material.young_modulus,
        "nu": design.material.poisson_ratio,
        "spec": [spec.fine, spec.grade, spec.coarse, spec.half_width, spec.depth, spec.spacing],
    }
    h.update(json.dumps(meta, sort_keys=True).encode())
    for name in ("ring", "frame", "cam"):
        o = outlines[name]
        h.update(name.encode())
        h.update(np.float64(o.thickness).tobytes())
        for c in o.contours:
            h.update(np.ascontiguousarray(c, dtype=np.float64).tobytes())
    return h.hexdigest()


def _read(path: Path) -> BodyTables | None:
    try:
        with np.load(path) as f:
            return BodyTables(
                ring=f["ring"],
                frame=f["frame"],
                frame_radii=f["frame_radii"],
                nodes=tuple(int(n) for n in f["nodes"]),
                mesh_size=float(f["mesh_size"]),
                cam=f["cam"],
            )
    except (OSError, KeyError, ValueError, IndexError):
        return None


def _write(path: Path, t: BodyTables) -> None:
    """Atomically (a temporary file, then a rename); a cache that cannot be written is skipped."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp.npz")
        np.savez(
            tmp,
            ring=t.ring,
            frame=t.frame,
            frame_radii=t.frame_radii,
            nodes=np.array(t.nodes),
            mesh_size=np.array(t.mesh_size),
            cam=t.cam,
        )
        os.replace(tmp, path)
    except OSError:
        pass


def cached_tables(design, outlines: dict, spec: MeshSpec | None = None) -> tuple[BodyTables, bool]:
    """``(tables, from_cache)`` of the design's bodies (see the module's docstring)."""
    spec = spec or MeshSpec()
    path = cache_dir() / "bodies" / f"{body_key(design, outlines, spec)}.npz"
    if path.is_file():
        t = _read(path)
        if t is not None:
            return t, True
    t = reduce_bodies(design, outlines, spec)
    _write(path, t)
    return t, False


def body_tables(ctx) -> BodyTables:
    """The scene's body tables, made (or read) once per run (``ctx``: the run's context;
    :mod:`~corr_cad.run.stages.context` imports this module, not the other way)."""
    if ctx.results.bodies is None:
        from corr_cad.geometry.parts import part_outlines
        from corr_cad.geometry.profile import working_profile

        s = ctx.scene
        working = working_profile(s.design, ctx.results.undercut)
        outlines = part_outlines(s.design, working, s.chord_tolerance)
        ctx.results.bodies, _ = cached_tables(s.design, outlines)
    return ctx.results.bodies


def design_tables(design, chord: float) -> BodyTables:
    """The body tables of another design than the scene's (a sweep's point), from its own
    outlines, cached as :func:`body_tables` caches the scene's (``chord``: ``[export]
    chord_tolerance``)."""
    from corr_cad.geometry.parts import part_outlines
    from corr_cad.geometry.profile import undercut_analysis, working_profile

    working = working_profile(design, undercut_analysis(design))
    return cached_tables(design, part_outlines(design, working, chord))[0]


def bodies_description(tables: BodyTables | None = None, with_crank: bool = False) -> dict:
    """What the files state of the elastic bodies (``bodies`` of forces and datasheet);
    ``with_crank``: the crankshaft and its support bearings are in the figure too."""
    out = {
        "model": "elastic: plane-stress finite elements (P2 triangles) of the drawn outlines",
        "ring": "each row's gear ring, thickness the face width, held on its outer edge all "
        "round (pressed into a rigid housing bore)",
        "frame": "the frame plates as drawn, each held on its inner rim (the output flange); "
        "a roller rests half its slot force on each of the two plates it runs through",
        "cams": "each cam an annulus of the drawn radii about its own centre (as on its "
        "eccentric), held at its bore",
        "read_depth": "each body's approach read 3 r / 8 below the contact (the contact law "
        "holds the indentation above it)",
        "in_figure": [
            "contacts (cam, ring, slot)",
            "eccentric bearings where given",
            "gear ring body",
            "frame body",
            "cam body",
        ],
        "not_in_figure": ["crankshaft", "support bearings", "output bearings", "housing"],
    }
    if with_crank:  # [crankshaft] / [bearings.crank] beside the bodies
        out["in_figure"].append("crankshaft and its support bearings ([crankshaft])")
        out["not_in_figure"] = ["output bearings", "housing"]
    if tables is not None:
        out["mesh_size_mm"] = tables.mesh_size
        out["mesh_nodes"] = dict(zip(("ring", "frame", "cam"), tables.nodes, strict=False))
    return out
