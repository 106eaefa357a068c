"""Tolerance checks, Monte Carlo and allocation."""

import subprocess
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

from corr_cad import GearDesign, SceneError
from corr_cad.run.scene.scene import parse_scene
from corr_cad.tolerance.allocation import allocate
from corr_cad.tolerance.checks import CHECK_METRICS, DATASHEET_METRICS, Checks, evaluate_checks
from corr_cad.tolerance.montecarlo import Distribution, SerialExecutor, monte_carlo

M0 = 1.1e5
TOL = {"roller_radius": Distribution("normal", 0.001), "cam_radius": Distribution("uniform", 0.002)}


def test_checks_margin_and_sense():
    r = evaluate_checks(
        {"peak_pressure": 1200.0, "min_loaded_rollers": 5.0},
        Checks(max_contact_pressure=1000.0, min_loaded_rollers=3),
    )
    assert r["max_contact_pressure"] == {
        "limit": 1000.0,
        "value": 1200.0,
        "margin": -200.0,
        "passed": False,
    }
    assert r["min_loaded_rollers"]["margin"] == 2.0 and r["min_loaded_rollers"]["passed"]


@pytest.mark.slow
def test_failing_check_exits_1_and_names_the_limit(tmp_path):
    scene = tmp_path / "c.toml"
    scene.write_text(
        '[export]\nformats = ["forces"]\n[load]\ninput_torque = 1.1e5\n'
        "[solver]\npositions = 104\n"
        "[checks]\nmax_contact_pressure = 1000.0\nmin_loaded_rollers = 3\n"
    )
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 1
    assert "check failed: max_contact_pressure" in r.stderr
    assert (
        "check max_contact_pressure: FAIL" in r.stdout
        and "check min_loaded_rollers: pass" in r.stdout
    )
    import json

    m = json.loads((tmp_path / "o" / "manifest.json").read_text())
    assert m["checks"]["max_contact_pressure"]["passed"] is False
    assert m["checks"]["max_contact_pressure"]["margin"] == pytest.approx(1000.0 - 1236.5, abs=1)


def _mc(executor, n=24, seed=3):
    return monte_carlo(GearDesign(), M0, TOL, n, seed, 36, executor=executor, chunk=8)


def test_monte_carlo_is_reproducible_across_executors():
    a = _mc(SerialExecutor())
    b = _mc(SerialExecutor())
    with ProcessPoolExecutor(max_workers=2) as pool:
        c = _mc(pool)
    for k in a.metrics:
        assert np.array_equal(a.metrics[k], b.metrics[k])
        assert np.array_equal(a.metrics[k], c.metrics[k])  # bit for bit
    d = _mc(SerialExecutor(), seed=4)
    assert not np.array_equal(a.metrics["peak_gear_force"], d.metrics["peak_gear_force"])


@pytest.mark.slow
def test_monte_carlo_on_a_local_dask_cluster():
    distributed = pytest.importorskip("dask.distributed")
    with (
        distributed.LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            host="127.0.0.1",
            dashboard_address=None,
            processes=True,
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        d = _mc(client)
    a = _mc(SerialExecutor())
    for k in a.metrics:
        assert np.array_equal(a.metrics[k], d.metrics[k])


def test_monte_carlo_metrics_match_a_direct_solve():
    from corr_cad.geometry.deviations import ManufacturingErrors
    from corr_cad.mechanics.row.solver import cycle_angles, solve_forces
    from corr_cad.tolerance.montecarlo import draw_samples

    mc = _mc(SerialExecutor(), n=8)
    units = draw_samples(TOL, 8, 3, 26)
    k = 5
    err = ManufacturingErrors(
        cam_radius_error=float(0.002 * units["cam_radius"][k]),
        roller_radius_errors=tuple(0.001 * units["roller_radius"][k]),
    )
    res = solve_forces(GearDesign(), M0, cycle_angles(36), errors=err)
    assert mc.metrics["peak_gear_force"][k] == pytest.approx(res.F_n.max(), rel=1e-12)
    assert mc.metrics["min_loaded_rollers"][k] == res.loaded_count.min()


ALL_KINDS = {
    "cam_radius": Distribution("uniform", 0.002),
    "eccentricity": Distribution("normal", 0.001),
    "cam_phase": Distribution("normal", 0.01),
    "roller_radius": Distribution("normal", 0.001),
    "slot_angle": Distribution("uniform", 0.005),
}


def test_draws_of_one_kind_do_not_change_when_another_is_added():
    """A tolerance's draws depend on the seed and its own kind only.

    Adding, removing or reordering the other tolerances of a scene must not
    move a kind's samples (else a sensitivity study that adds one tolerance
    compares different samples of the others).
    """
    from corr_cad.tolerance.montecarlo import draw_samples

    alone = {k: draw_samples({k: d}, 7, 11, 26)[k] for k, d in ALL_KINDS.items()}
    together = draw_samples(ALL_KINDS, 7, 11, 26)
    backwards = draw_samples(dict(reversed(list(ALL_KINDS.items()))), 7, 11, 26)
    pairs = {
        k: draw_samples({"roller_radius": ALL_KINDS["roller_radius"], k: d}, 7, 11, 26)[k]
        for k, d in ALL_KINDS.items()
    }
    for k in ALL_KINDS:
        assert np.array_equal(together[k], alone[k]), k
        assert np.array_equal(backwards[k], alone[k]), k
        assert np.array_equal(pairs[k], alone[k]), k
    # and what the Monte Carlo solves: the roller radius errors' magnitudes per sample
    one = {"roller_radius": ALL_KINDS["roller_radius"]}
    two = {**one, "cam_radius": ALL_KINDS["cam_radius"]}
    a = monte_carlo(GearDesign(), M0, one, 5, 11, 12, kernel=False)
    b = monte_carlo(GearDesign(), M0, two, 5, 11, 12, kernel=False)
    assert np.array_equal(a.magnitudes["roller_radius"], b.magnitudes["roller_radius"])


def test_summary_has_percentiles_failures_and_ranking():
    mc = _mc(SerialExecutor(), n=40)
    s = mc.summary(Checks(max_contact_pressure=2000.0))
    # Every check's metric but the datasheet's (judged on the nominal design only).
    assert set(s["percentiles"]) == {
        m for m, _ in CHECK_METRICS.values() if m not in DATASHEET_METRICS
    }
    p = s["percentiles"]["peak_pressure"]
    assert p["p5"] <= p["p50"] <= p["p95"] <= p["p99"]
    expected = np.mean(mc.metrics["peak_pressure"] > 2000.0)
    assert s["failure_probability"]["max_contact_pressure"] == expected
    assert [r["tolerance"] for r in s["sensitivity"]] and s["sensitivity"][0]["score"] >= s[
        "sensitivity"
    ][-1]["score"]


def test_allocation_found_tolerance_passes_and_ten_percent_more_fails():
    design = GearDesign()
    checks = Checks(max_gear_force=5000.0)
    kw = {"percentile": 90.0, "samples": 30, "seed": 2, "positions": 36}
    r = allocate(design, M0, {}, checks, "roller_radius", **kw)
    T = r["tolerance"]
    assert T > 0 and r["failing_at"] <= 1.1 * T

    def p90(t):
        mc = monte_carlo(design, M0, {"roller_radius": Distribution("uniform", t)}, 30, 2, 36)
        return np.percentile(mc.metrics["peak_gear_force"], 90.0)

    assert p90(T) <= 5000.0
    assert p90(1.1 * T) > 5000.0


def test_allocation_answers_as_sigma_when_the_tolerance_was_a_sigma():
    design = GearDesign()
    checks = Checks(max_gear_force=5000.0)
    kw = {"percentile": 90.0, "samples": 30, "seed": 2, "positions": 36}
    given = {"roller_radius": Distribution("normal", 0.001)}
    r = allocate(design, M0, given, checks, "roller_radius", **kw)
    assert (r["distribution"], r["meaning"]) == ("normal", "sigma")
    T = r["tolerance"]
    assert T > 0 and r["failing_at"] <= 1.1 * T

    def p90(t):
        mc = monte_carlo(design, M0, {"roller_radius": Distribution("normal", t)}, 30, 2, 36)
        return np.percentile(mc.metrics["peak_gear_force"], 90.0)

    # T is a sigma: normal draws of sigma T pass, 10 % more fail.
    assert p90(T) <= 5000.0 < p90(1.1 * T)
    u = allocate(design, M0, {}, checks, "roller_radius", **kw)
    assert u["meaning"] == "uniform half-width" and u["tolerance"] != T


@pytest.mark.parametrize(
    "data,pattern",
    [
        (
            {"tolerances": {"roller_radius": {"gauss": 0.001}}},
            "distribution 'gauss' must be one of normal, uniform",
        ),
        ({"tolerances": {"roller_radius": 0.001}}, r"must be \{ normal = sigma \}"),
        (
            {"tolerances": {"gear_pitch": {"normal": 0.001}}},
            "unknown key 'gear_pitch' in \\[tolerances\\]",
        ),
        ({"tolerances": {"cam_radius": {"normal": -1.0}}}, "allowed range is \\[0, inf\\)"),
        (
            {"export": {"formats": ["montecarlo"]}, "load": {"input_torque": 1.0}},
            "\\[tolerances\\] is empty",
        ),
        (
            {
                "export": {"formats": ["montecarlo"]},
                "tolerances": {"cam_radius": {"normal": 0.001}},
            },
            "need a torque",
        ),
        (
            {
                "export": {"formats": ["allocation"]},
                "load": {"input_torque": 1.0},
                "tolerances": {"cam_radius": {"normal": 0.001}},
            },
            "allocation needs at least one limit",
        ),
        ({"errors": {"slot_angle_errors_deg": [0.0]}}, "has 1 values; the design has 26 slots"),
        (
            {"errors": {"profile_deviation_harmonics": [[3.0, 0.001]]}},
            "list of \\[order, amplitude, phase\\] rows",
        ),
    ],
)
def test_bad_tolerance_scenes(data, pattern):
    with pytest.raises(SceneError, match=pattern):
        parse_scene(data)


@pytest.mark.slow
def test_cli_runs_monte_carlo_on_a_dask_scheduler(tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    scene = tmp_path / "mc.toml"
    scene.write_text(
        '[export]\nformats = ["montecarlo"]\n[load]\ninput_torque = 1.1e5\n'
        "[tolerances]\nroller_radius = { normal = 0.001 }\n"
        "[montecarlo]\nsamples = 20\nseed = 5\npositions = 36\n"
    )
    outs = {}
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, host="127.0.0.1", dashboard_address=None
    ) as cluster:
        for ex in ("dask", "serial", "process"):
            args = ["--executor", ex] + (
                ["--scheduler", cluster.scheduler_address] if ex == "dask" else []
            )
            out = tmp_path / ex
            r = subprocess.run(
                [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(out), *args],
                capture_output=True,
                text=True,
            )
            assert r.returncode == 0, r.stderr
            outs[ex] = (out / "montecarlo.csv").read_bytes()
    assert outs["dask"] == outs["serial"] == outs["process"]
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--executor", "dask"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert r.returncode == 2 and "--scheduler" in r.stderr
