"""The first run after install compiles the numerical kernels once; a later run in a
fresh process compiles nothing (numba's own record: ``NUMBA_DEBUG_CACHE`` prints what
it saves and loads), and ``corr-cad warm-up`` compiles them ahead."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

DRIVE_MC = """[export]
formats = ["montecarlo"]
[load]
input_torque = 1.1e5
[solver]
model = "drive"
contact_law = "palmgren"
[tolerances]
roller_radius = { uniform = 0.002 }
[montecarlo]
samples = 4
positions = 8
seed = 1
datasheet_positions_per_mesh = 1
[checks]
max_lost_motion_arcmin = 5.0
[bearings.eccentric]
needles = 40
needle_diameter = 6.0
needle_length = 12.0
diametral_clearance = 0.005
"""


def _cli(*args, cwd, **env):
    return subprocess.run(
        [sys.executable, "-m", "corr_cad", *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        env={**os.environ, "PYTHONPATH": str(ROOT), **env},
    )


def test_a_second_run_of_a_drive_monte_carlo_compiles_nothing(tmp_path):
    first = _cli("warm-up", cwd=tmp_path)  # compiles only what the cache lacks
    assert first.returncode == 0, first.stderr
    again = _cli("warm-up", cwd=tmp_path, NUMBA_DEBUG_CACHE="1")
    assert again.returncode == 0, again.stderr
    assert "groups compiled, the rest loaded from cache" in again.stdout
    assert "0 of 5 groups compiled" in again.stdout, again.stdout
    scene = tmp_path / "drive_mc.toml"
    scene.write_text(DRIVE_MC)
    run = _cli("run", str(scene), "--out", "out", cwd=tmp_path, NUMBA_DEBUG_CACHE="1")
    assert run.returncode == 0, run.stderr
    record = run.stdout + run.stderr
    assert "[cache] data loaded" in record  # the kernels ran, from the cache
    assert "[cache] data saved" not in record  # and none was compiled
    assert "compiling the numerical kernels" not in record
    # The elastic bodies' kernels (their group's run: the influence matrices and the
    # Newton, cams fixed and on needles, both laws) load from the cache too.
    code = "from corr_cad.run import warmup; warmup._bodies_kernels()"
    bodies = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_DEBUG_CACHE": "1"},
    )
    assert bodies.returncode == 0, bodies.stderr
    record = bodies.stdout + bodies.stderr
    assert "[cache] data loaded" in record and "[cache] data saved" not in record, record


def test_an_empty_cache_lacks_every_group(tmp_path, monkeypatch):
    """The check reads the cache's index files: an empty ``NUMBA_CACHE_DIR`` has none."""
    from corr_cad.run.warmup import GROUPS, missing

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    assert missing() == [g[0] for g in GROUPS]


def test_which_groups_a_scene_uses():
    from corr_cad.run.scene.scene import parse_scene
    from corr_cad.run.warmup import scene_groups

    assert scene_groups(parse_scene({"export": {"formats": ["dxf"]}})) == []
    load = {"load": {"input_torque": 1.1e5}}
    drive = parse_scene({**load, "solver": {"model": "drive"}, "export": {"formats": ["forces"]}})
    assert scene_groups(drive) == ["free-play kernel"]
    mc = parse_scene(
        {
            **load,
            "solver": {"model": "drive"},
            "export": {"formats": ["montecarlo"]},
            "tolerances": {"roller_radius": {"uniform": 0.001}},
        }
    )
    assert scene_groups(mc) == ["free-play kernel", "drive kernels"]
    elastic = parse_scene(
        {
            **load,
            "solver": {"model": "drive", "bodies": "elastic"},
            "export": {"formats": ["forces"]},
        }
    )
    assert scene_groups(elastic) == ["free-play kernel", "bodies kernels"]


def test_a_small_monte_carlo_of_the_paper_s_row_needs_no_kernel():
    """It runs the numpy solver; with the datasheet metrics both paper kernels."""
    from corr_cad.run.scene.scene import parse_scene
    from corr_cad.run.warmup import scene_groups

    base = {
        "load": {"input_torque": 1.1e5},
        "export": {"formats": ["montecarlo"]},
        "tolerances": {"roller_radius": {"uniform": 0.001}},
    }
    assert scene_groups(parse_scene(base)) == []
    gated = parse_scene({**base, "checks": {"max_lost_motion_arcmin": 3.0}})
    assert scene_groups(gated) == ["Monte Carlo kernel", "datasheet windup kernel"]


def test_an_index_older_than_its_source_is_missing(tmp_path, monkeypatch):
    """numba recompiles a kernel whose source changed after its cache (an upgrade): an
    index file older than the module counts as missing, a newer one as cached."""
    import os
    import re

    from corr_cad.run import warmup

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    source = warmup.source("free_play")
    names = re.findall(r"^@_jit\s*\ndef (\w+)", source.read_text(), re.M)
    group = [g for g in warmup.GROUPS if g[1] == ("free_play",)]
    for name in names:
        (tmp_path / f"free_play.{name}-1.py311.nbi").write_bytes(b"")
    assert warmup.missing(group) == []
    stamp = source.stat().st_mtime - 10.0
    for name in names[:1]:
        os.utime(tmp_path / f"free_play.{name}-1.py311.nbi", (stamp, stamp))
    assert warmup.missing(group) == ["free-play kernel"]


def test_the_chains_hold_every_group_once():
    from corr_cad.run.warmup import CHAINS, GROUPS

    assert sorted(n for c in CHAINS for n in c) == sorted(g[0] for g in GROUPS)


@pytest.mark.slow
def test_a_warm_up_in_processes_from_an_empty_cache_compiles_every_group_once(tmp_path):
    """From an empty cache the warm-up compiles every group, its chains in parallel
    processes (where the machine's load leaves cores idle, as here asked for two); a
    second ``corr-cad warm-up`` compiles nothing (numba's own record)."""
    env = {"NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    code = "from corr_cad.run import warmup; warmup.command(workers=2)"
    first = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(ROOT), **env},
    )
    assert first.returncode == 0, first.stderr
    assert "5 of 5 groups compiled" in first.stdout, first.stdout
    assert "compiling in 2 processes" in first.stdout, first.stdout
    assert first.stdout.count("      compiled: ") == 3, first.stdout  # one line per chain
    again = _cli("warm-up", cwd=tmp_path, NUMBA_DEBUG_CACHE="1", **env)
    assert again.returncode == 0, again.stderr
    assert "0 of 5 groups compiled" in again.stdout, again.stdout
    record = again.stdout + again.stderr
    assert "[cache] data loaded" in record and "[cache] data saved" not in record, record
