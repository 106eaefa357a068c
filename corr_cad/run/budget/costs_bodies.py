"""What ``[solver] bodies = "elastic"`` adds to the estimate of the stages that solve the drive.

The finite-element reduction when its tables are not cached (the prototype: 450 MB
peak, 2.6-4.9 CPU s on the shared 2 cores), and the elastic solve against the rigid
one (about 10 times with the cams fixed, twice on needle bearings: ``corr-cad bench
--study bodies``).
"""

from __future__ import annotations

from dataclasses import replace

__all__ = [
    "BODIES_MEMORY",
    "BODIES_SECONDS",
    "ELASTIC_SOLVE",
    "ELASTIC_SOLVE_NEEDLES",
    "elastic_terms",
    "reduce_once",
    "reduction_seconds",
    "stage_terms",
]

MB = 1024 * 1024
BODIES_MEMORY, BODIES_SECONDS, ELASTIC_SOLVE = 500 * MB, 10.0, 10
#: The elastic solve against the rigid one with the cams on needle bearings (the module's
#: "twice"): the datasheet stage of the prototype on 40 needles with 5 um of clearance,
#: 1.3 s elastic against 0.7 s rigid (``templates/compound.toml`` as a drive).
ELASTIC_SOLVE_NEEDLES = 2
#: Reading the scene's cached tables (a few MB of ``.npz``).
BODIES_CACHED_SECONDS = 0.1


def elastic_terms(scene) -> tuple[float, float, float]:
    """``(memory bytes, seconds, solve factor)``: ``(0, 0, 1)`` with rigid bodies (the
    estimate then keeps its numbers bit for bit)."""
    if scene.solver.bodies != "elastic":
        return 0, 0, 1
    return BODIES_MEMORY, BODIES_SECONDS, ELASTIC_SOLVE


def _cached(scene) -> bool:
    """Whether the scene's own body tables are in the cache (the outlines cost ~0.07 s)."""
    try:
        from corr_cad.geometry.parts import part_outlines
        from corr_cad.geometry.profile import undercut_analysis, working_profile
        from corr_cad.mechanics.bodies.reduction import MeshSpec
        from corr_cad.run.stages.stages_bodies import body_key, cache_dir

        d = scene.design
        outlines = part_outlines(d, working_profile(d, undercut_analysis(d)), scene.chord_tolerance)
        return (cache_dir() / "bodies" / f"{body_key(d, outlines, MeshSpec())}.npz").is_file()
    except Exception:  # noqa: BLE001 - an estimate never fails a run; uncached is the worst case
        return False


def stage_terms(scene) -> tuple[float, float, float]:
    """:func:`elastic_terms` of a stage that solves the scene's own design (forces, the
    datasheet): the FE reduction's seconds only when its tables are not cached, the
    elastic solve's factor on needle bearings where the scene has them."""
    if scene.solver.bodies != "elastic":
        return 0, 0, 1
    needles = getattr(scene, "bearing", None) is not None
    return (
        BODIES_MEMORY,
        BODIES_CACHED_SECONDS if _cached(scene) else BODIES_SECONDS,
        ELASTIC_SOLVE_NEEDLES if needles else ELASTIC_SOLVE,
    )


def reduction_seconds(scene) -> float:
    """The FE reduction's seconds that :func:`stage_terms` counts beyond reading the
    tables (0 with rigid bodies or the tables cached): a run reduces the bodies once, in
    the first stage that solves on them, and the later ones read the tables it cached."""
    if scene.solver.bodies != "elastic":
        return 0.0
    return stage_terms(scene)[1] - BODIES_CACHED_SECONDS


def reduce_once(scene, costs: dict) -> None:
    """The run's stage costs ``costs`` (name -> Cost) with the FE reduction counted once:
    the datasheet after the forces reads the tables the forces made (in place)."""
    if "forces" in costs and "datasheet" in costs:
        sheet = costs["datasheet"]
        costs["datasheet"] = replace(sheet, seconds=sheet.seconds - reduction_seconds(scene))
