"""Design a profile modification to targets (issue 20, item 3), through the CLI.

Small settings (60 samples, 4 x 4 grid, 32 positions) keep it fast; the
prototype with four tolerances, as the issue's speed case.
"""

import json
import subprocess
import sys
import tomllib

import pytest

SCENE = """
[export]
formats = ["modification"]
[load]
input_torque = 1.1e5
[tolerances]
cam_radius = {{ uniform = 0.005 }}
eccentricity = {{ uniform = 0.005 }}
roller_radius = {{ normal = 0.002 }}
slot_angle = {{ normal = 0.002 }}
[modification.design]
target_backlash_arcmin = {target}
max_binding_probability = 0.05
family = "equidistant+shift"
equidistant_range_mm = [0.0, 0.03]
shift_range_mm = [-0.01, 0.02]
steps = 4
samples = 60
positions = 32
force_candidates = 2
"""


def _run(folder, target, executor="serial"):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "s.toml").write_text(SCENE.format(target=target))
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet",
         "--executor", executor],
        cwd=folder,
        capture_output=True,
        text=True,
    )  # fmt: skip
    return r, folder / "out"


@pytest.fixture(scope="module")
def designed(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("designed"), 2.0)


def test_candidate_clearance_is_subtracted_at_each_samples_own_positions():
    """gap_metrics stacks samples sample-major (rows k P .. k P + P - 1); a clearance that
    differs position by position must meet each sample at its own positions. The free
    rotation written out: fwd = min over a > 0 of -g/a, rev = max over a < 0, per row."""
    from types import SimpleNamespace

    import numpy as np

    from corr_cad import GearDesign
    from corr_cad.tolerance.modification_design import gap_metrics

    d = GearDesign()
    n, P, R = 3, 4, d.roller_count
    rng = np.random.default_rng(5)
    psi = rng.uniform(-3.0, 3.0, (n * P, R))
    advance = np.sin(psi)
    rho_n = 1.0 + 0.1 * np.cos(psi)
    gap = -rng.uniform(0.0, 0.002, (n * P, R))
    clearance = np.linspace(0.0, 0.006, P * R).reshape(P, R)  # every cell its own value
    geo = SimpleNamespace(
        gap=gap, advance=advance, loadable=np.ones_like(gap, dtype=bool), rho_n=rho_n
    )
    backlash, binds = gap_metrics(geo, n, d, clearance)
    want = []
    for k in range(n):
        worst = 0.0
        for p in range(P):
            row = k * P + p
            g = gap[row] - rho_n[row] * clearance[p]
            a = advance[row]
            fwd = min(-g[i] / a[i] for i in range(R) if a[i] > 0)
            rev = max(-g[i] / a[i] for i in range(R) if a[i] < 0)
            worst = max(worst, max(fwd - rev, 0.0) / R)
        want.append(worst * 60 * 180 / np.pi)
    np.testing.assert_allclose(backlash, want, rtol=1e-12)
    assert not binds.any()


@pytest.mark.slow
def test_design_writes_its_files_and_meets_the_targets(designed):
    r, out = designed
    assert r.returncode == 0, r.stderr
    res = json.loads((out / "modification.json").read_text())
    c = res["chosen"]
    assert res["met"] and c["meets_backlash"] and c["meets_binding"]
    assert c["backlash_arcmin"]["p95"]["value"] <= 2.0
    assert c["binding_probability"]["value"] <= 0.05
    for q in ("p50", "p95", "p99"):  # each estimate with its sampling error
        lo, hi = c["peak_pressure_MPa"][q]["range"]
        assert lo <= c["peak_pressure_MPa"][q]["value"] <= hi
    assert "standard_error" in c["binding_probability"]
    assert (out / "modification_tradeoff.png").stat().st_size > 10_000


@pytest.mark.slow
def test_modified_toml_meets_the_targets_with_a_fresh_seed(designed):
    from corr_cad.run.scene.scene import load_scene
    from corr_cad.tolerance.modification_design import design_modification

    _, out = designed
    mod = load_scene(out / "modified.toml").modification
    scene = load_scene(out.parent / "s.toml")  # the tolerances it was designed under
    chosen = json.loads((out / "modification.json").read_text())["chosen"]
    assert (mod.equidistant_mm, mod.shift_mm) == (chosen["equidistant_mm"], chosen["shift_mm"])
    res = design_modification(
        scene.design,
        scene.tolerances,
        family="equidistant+shift",
        objective="peak_pressure",
        target_backlash_arcmin=2.0,
        max_binding_probability=0.05,
        crank_moment=1.1e5,
        equidistant_mm=(mod.equidistant_mm, mod.equidistant_mm, 1),
        shift_mm=(mod.shift_mm, mod.shift_mm, 1),
        samples=400,
        seed=12345,  # fresh
        positions=32,
        force_candidates=1,
    )
    c = res["candidates"][0]
    se = c["binding_probability"]["standard_error"]
    assert c["backlash_arcmin"]["p95"]["range"][0] <= 2.0
    assert c["binding_probability"]["value"] <= 0.05 + 3 * max(se, 0.01)
    # and the file runs for the shop files
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(out / "modified.toml"), "--out",
         str(out.parent / "shop"), "--quiet"],
        capture_output=True,
        text=True,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert tomllib.loads((out / "modified.toml").read_text())["modification"]["shift_mm"] == (
        mod.shift_mm
    )


@pytest.mark.slow
def test_unmet_targets_name_the_binding_target_and_exit_1(tmp_path):
    r, out = _run(tmp_path, 0.1)
    assert r.returncode == 1
    assert "targets unmet" in r.stderr and "target_backlash_arcmin = 0.1" in r.stderr
    res = json.loads((out / "modification.json").read_text())
    assert not res["met"] and res["chosen"] is not None  # the best it could do


@pytest.mark.slow
def test_results_identical_on_every_executor(designed, tmp_path):
    _, out = designed
    r, out2 = _run(tmp_path, 2.0, executor="process")
    assert r.returncode == 0, r.stderr
    assert (out / "modification.json").read_bytes() == (out2 / "modification.json").read_bytes()


@pytest.mark.slow
def test_results_identical_on_a_dask_scheduler(designed, tmp_path):
    """The search's samples run on a real local Dask cluster: the same bytes."""
    distributed = pytest.importorskip("dask.distributed")
    _, out = designed
    tmp_path.mkdir(parents=True, exist_ok=True)
    (tmp_path / "s.toml").write_text(SCENE.format(target=2.0))
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, host="127.0.0.1", dashboard_address=None
    ) as cluster:
        r = subprocess.run(
            [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet",
             "--executor", "dask", "--scheduler", cluster.scheduler_address],
            cwd=tmp_path,
            capture_output=True,
            text=True,
        )  # fmt: skip
    assert r.returncode == 0, r.stderr
    got = (tmp_path / "out" / "modification.json").read_bytes()
    assert got == (out / "modification.json").read_bytes()


@pytest.mark.slow
def test_free_family_writes_its_curve_and_modified_toml_runs_it(tmp_path):
    text = SCENE.format(target=3.5).replace(
        'family = "equidistant+shift"', 'family = "free"\nobjective = "transmission_error"'
    )
    text = text.replace("steps = 4", "steps = 2").replace("samples = 60", "samples = 40")
    text += "[datasheet]\npositions_per_mesh = 2\ntransmission_error_positions_per_turn = 4\n"
    (tmp_path / "s.toml").write_text(text)
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet",
         "--executor", "serial"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    res = json.loads((tmp_path / "out" / "modification.json").read_text())
    assert len(res["candidates"]) == 16 and res["met"]
    c = res["chosen"]
    assert c["transmission_error_arcsec_nominal"] == min(
        x["transmission_error_arcsec_nominal"] for x in res["candidates"] if x.get("force_solved")
    )
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "out/modified.toml", "--out", "shop",
         "--quiet"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    m = json.loads((tmp_path / "shop" / "manifest.json").read_text())
    assert m["modification"]["families"] == ["normal_table"]
    at = m["modification"]["flank_clearance_mm"]["at_psi_deg"]
    assert at["0"] == pytest.approx(c["normal_mm"][0], abs=1e-6)  # the curve at psi 0
