"""Pipeline stages for the profile: undercut, exact profiles, DXF, preview, measured profile.

Registered in :data:`corr_cad.run.stages.stages.STAGES`.
"""

from __future__ import annotations

import os

from corr_cad.errors import ProfileError
from corr_cad.geometry.profile import theoretical_profile, undercut_analysis, working_profile
from corr_cad.geometry.sampling import approximate
from corr_cad.run.stages.context import RunContext, expected_seconds, modified_curve


def _undercut(ctx: RunContext) -> None:
    info = undercut_analysis(ctx.scene.design)
    ctx.results.undercut = info
    ctx.manifest["undercut"] = info.as_dict()
    if ctx.scene.modification is not None:
        from corr_cad.run.stages.stages_modification import modification_manifest

        ctx.manifest["modification"] = modification_manifest(ctx)


def _profiles(ctx: RunContext) -> None:
    d = ctx.scene.design
    ctx.results.working = working_profile(d, ctx.results.undercut)
    if ctx.scene.modification is not None:
        ctx.results.conjugate = ctx.results.working
        ctx.results.working = modified_curve(ctx)
    ctx.results.theoretical = theoretical_profile(d)
    ctx.manifest["profile"] = {
        "working_area_mm2": ctx.results.working.area(),
        "theoretical_area_mm2": ctx.results.theoretical.area(),
        "tooth_tip_trimmed": ctx.results.working.has_corners,
    }


def _dxf_geometry(ctx: RunContext) -> None:
    from corr_cad.run.progress import Progress

    s = ctx.scene
    # A fine tolerance takes seconds per profile: a line with rate and time left.
    conj = ctx.results.conjugate
    bar = Progress(
        2 if conj is None else 3,
        f"      dxf profiles ({s.representation}, {s.tolerance:g} mm)",
        "profiles",
        expected=expected_seconds(ctx, "dxf_geometry"),
    )
    w = approximate(ctx.results.working, s.representation, s.tolerance)
    if conj is not None and not w.within_tolerance:
        bar.close()
        _refuse_modified(s, w)
    bar.update(1)
    t = approximate(ctx.results.theoretical, s.representation, s.tolerance)
    bar.update(1)
    if conj is not None:
        ctx.results.conjugate_approx = approximate(conj, s.representation, s.tolerance)
        bar.update(1)
    bar.close()
    ctx.results.working_approx = w
    ctx.results.theoretical_approx = t
    # Where each figure goes: the run fails (exit 1) naming them if the
    # measured deviation exceeds the tolerance (the files still state the
    # measured value, never the tolerance).
    where = {"file": "inner_gear.dxf"}
    ctx.manifest["accuracy"] = {
        "working_profile": {**w.as_dict(), **where, "layer": "WORKING_PROFILE"},
        "theoretical_profile": {**t.as_dict(), **where, "layer": "THEORETICAL_PROFILE"},
    }
    if conj is not None:
        ctx.manifest["accuracy"]["conjugate_profile"] = {
            **ctx.results.conjugate_approx.as_dict(),
            **where,
            "layer": "CONJUGATE_PROFILE",
        }
    if s.first_stage is not None:
        from corr_cad.run.stages.stages_first_stage import gear_outlines

        outlines = gear_outlines(ctx, s.tolerance)
        for part, o in outlines.items():
            ctx.manifest["accuracy"][f"{part}_profile"] = {
                **o.as_dict(),
                "file": f"{part}.dxf",
                "layer": "PROFILE",
            }


def _refuse_modified(s, w) -> None:
    """A modified curve the approximation cannot follow: refused before any file is written.

    The conjugate profile's limits are known in advance (the tolerance floors
    of :mod:`corr_cad.run.scene.limits`); a normal table that bends the curve
    sharper than the tolerance can follow is found here, by the
    approximation itself, in the stage before the files.
    """
    from corr_cad.errors import SceneError

    table = s.modification.normal_table
    what = f"[modification] {table.source}" if table is not None else "[modification]"
    fix = "a table of gentler swings" if table is not None else "a smaller modification"
    raise SceneError(
        f"[export] tolerance = {s.tolerance:g}: the modified working profile cannot be drawn "
        f"within it: {what} bends it too sharply (measured max deviation "
        f"{w.max_deviation:.3g} mm, {w.representation}, {w.entity_vertex_count} vertices); "
        f"{fix} or a larger tolerance; nothing was written"
    )


def _dxf_files(ctx: RunContext) -> None:
    from corr_cad.export import dxf
    from corr_cad.run.stages.stages_bearing_parts import needle_rows_of

    mod = ctx.scene.modification
    rows = needle_rows_of(ctx)
    paths = dxf.write_all(
        ctx.scene.design,
        ctx.results.working_approx,
        ctx.results.theoretical_approx,
        ctx.out,
        ctx.results.conjugate_approx,
        None if mod is None else {"equidistant_mm": mod.equidistant_mm, "shift_mm": mod.shift_mm},
        floating=rows is not None,
    )
    ctx.files.extend(p.name for p in paths.values())
    if ctx.scene.first_stage is not None:
        from corr_cad.export.gear_dxf import write_gears, write_round_part
        from corr_cad.geometry.first_stage_parts import first_stage_profiles

        s, outlines = ctx.scene, ctx.results.gear_outlines
        gears = write_gears(s.design, s.first_stage, outlines, ctx.out)
        verts = {k: o.vertices for k, o in outlines.items()}
        profiles = first_stage_profiles(s.design, s.first_stage, verts, rows)
        for part in ("crankshaft", "wheel_bearing", "crank_bearing"):
            gears.append(write_round_part(s.design, part, profiles[part], ctx.out / f"{part}.dxf"))
        ctx.files.extend(p.name for p in gears)
    if rows is not None:
        from corr_cad.run.stages.stages_bearing_parts import dxf_files

        dxf_files(ctx, rows)


def _preview_png(ctx: RunContext) -> None:
    from corr_cad.export import plots

    mod = ctx.scene.modification
    label = ""
    if mod is not None and not mod.is_zero:
        from corr_cad.geometry.modification import amounts_text

        label = amounts_text(mod)
    p = plots.preview_png(
        ctx.scene.design,
        ctx.results.working,
        ctx.results.theoretical,
        ctx.out / "preview.png",
        modification=label,
    )
    ctx.files.append(p.name)
    if ctx.scene.first_stage is not None:
        from corr_cad.export.first_stage_plots import first_stage_png
        from corr_cad.run.stages.stages_first_stage import gear_outlines

        outlines = gear_outlines(ctx, ctx.scene.tolerance)
        verts = {k: o.vertices for k, o in outlines.items()}
        p = first_stage_png(
            ctx.scene.design, ctx.scene.first_stage, verts, ctx.out / "first_stage.png"
        )
        ctx.files.append(p.name)
    if ctx.scene.modification is not None:
        from corr_cad.run.stages.stages_modification import modification_png

        modification_png(ctx)


def _sha256(path) -> str:
    """SHA-256 of a file already read (and size-checked) as the measured profile."""
    import hashlib

    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _flat_points(ctx: RunContext) -> int:
    """Most points a measured DXF contour may flatten to: what the memory budget has
    left beside this process's present size, at most ``MAX_FLATTENED_POINTS``."""
    from corr_cad.export.measured_io import FLAT_BYTES_PER_POINT, MAX_FLATTENED_POINTS

    budget = getattr(ctx.budget, "memory_bytes", None)
    if budget is None:  # run_scene always sets it; a bare context has no budget
        return MAX_FLATTENED_POINTS
    try:
        with open("/proc/self/statm") as fh:
            used = int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        used = 0
    free = max(0.0, budget - used)
    return int(min(MAX_FLATTENED_POINTS, free // FLAT_BYTES_PER_POINT))


def _register(ctx: RunContext, path, key: str):
    """Read, check and register one measured ring; its manifest entry under ``key``."""
    from corr_cad.export.measured_io import MAX_MEASURED_POINTS, read_measured
    from corr_cad.tolerance.measured import check_fit, register, validate_points

    s, w = ctx.scene, ctx.results.working
    src = str(path)
    knob = "[errors.row_b] measured_profile" if key.endswith("_b") else "[errors] measured_profile"
    try:
        got = read_measured(path, design=s.design, max_flat_points=_flat_points(ctx))
    except ProfileError as exc:
        raise ProfileError(f"{knob}: {exc}") from exc
    if got.stride > 1:
        ctx.progress(
            f"      measured profile: {got.rows} points read, 1 in {got.stride} kept "
            f"({len(got.points)} points, at most {MAX_MEASURED_POINTS}: "
            f"{len(got.points) // s.design.tooth_count} a tooth)"
        )
    try:
        pts = validate_points(got.points, w, src)
        reg = register(w, pts)
        check_fit(reg, s.design.eccentricity, src)
    except ProfileError as exc:
        raise ProfileError(f"{knob}: {exc}") from exc
    ctx.manifest[key] = {
        "source": path.name,
        "sha256": _sha256(path),
        **reg.as_dict(),
        "read": got.as_dict(),
    }
    ctx.progress(
        f"      registered{' ring B' if key.endswith('_b') else ''}: rotation "
        f"{reg.rotation_deg:.4g} deg, centre ({reg.centre_mm[0]:.4g}, {reg.centre_mm[1]:.4g}) "
        f"mm, rms {reg.rms_mm:.3g} mm"
    )
    return reg, pts


def _measured(ctx: RunContext) -> None:
    from dataclasses import replace

    from corr_cad.export.measured_io import write_deviation_dxf

    s = ctx.scene
    w = ctx.results.working
    if getattr(s, "measured_profile_b", None) is not None:
        # Ring B's measured contour (``[errors.row_b]``): its deviation is row B's.
        reg_b, pts_b = _register(ctx, s.measured_profile_b, "measured_profile_b")
        ctx.results.registration_b, ctx.results.measured_points_b = reg_b, pts_b
    if s.measured_profile is None:
        return
    reg, pts = _register(ctx, s.measured_profile, "measured_profile")
    ctx.results.registration, ctx.results.measured_points = reg, pts
    ctx.results.errors = replace(s.errors, profile_deviation=reg.deviation)
    if "dxf" in s.formats:
        write_deviation_dxf(
            s.design,
            w,
            reg.placed,
            reg.point_deviation,
            reg.point_t,
            s.measured_exaggeration,
            ctx.out / "measured_profile.dxf",
            s.tolerance,
        )
        ctx.files.append("measured_profile.dxf")
