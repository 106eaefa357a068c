# ruff: noqa: E501  (the mutations are exact source lines)
"""The mutation campaign: one realistic mistake at a time, the tests that must catch it.

Run from the repository root:  python tests/mutation_campaign.py [INDEX ...]
Each mutation is applied to the source, the named tests run in a subprocess,
and the file is restored (also on Ctrl-C). Prints one row per mutation:
index | CAUGHT or MISSED | file | mistake | tests | first failing test.
Not collected by pytest (the file name does not start with test_).
"""

import os
import pathlib
import subprocess
import sys

WT = pathlib.Path(__file__).resolve().parents[1]
M = [
    (
        "tolerance/montecarlo.py",
        'math.radians(float(v["cam_phase"]))',
        'float(v["cam_phase"])',
        "MC cam phase tolerance deg used as rad",
        "tests/test_physics.py::test_montecarlo_metrics_equal_direct_solves",
    ),
    (
        "tolerance/montecarlo.py",
        'np.radians(v["slot_angle"])',
        'v["slot_angle"]',
        "MC slot angle tolerance deg used as rad",
        "tests/test_physics.py::test_montecarlo_metrics_equal_direct_solves",
    ),
    (
        "geometry/deviations.py",
        "math.radians(float(p))",
        "float(p)",
        "harmonic phase deg used as rad",
        "tests/test_physics.py -k phase_is_in_degrees or scene_angles",
    ),
    (
        "tolerance/checks.py",
        "ARCMIN_PER_RAD = 180.0 * 60.0 / math.pi",
        "ARCMIN_PER_RAD = 180.0 / math.pi",
        "lost motion in degrees, labelled arcmin",
        "tests/test_physics.py::test_backlash_in_arcmin_against_hand_calculation",
    ),
    (
        "mechanics/solver.py",
        "return play / g.psi.shape[1]",
        "return play",
        "lost motion: crank play not divided by z + 1",
        "tests/test_physics.py::test_backlash_in_arcmin_against_hand_calculation",
    ),
    (
        "tolerance/checks.py",
        "p = np.maximum(np.maximum(res.p_cam, res.p_slot), res.p_gear)",
        "p = np.maximum(res.p_cam, res.p_slot)",
        "MC peak pressure leaves out the gear contact",
        "tests/test_physics.py::test_montecarlo_metrics_equal_direct_solves",
    ),
    (
        "tolerance/checks.py",
        "p = np.maximum(np.maximum(res.p_cam, res.p_slot), res.p_gear)",
        "p = np.maximum(res.p_gear, res.p_slot)",
        "MC peak pressure leaves out the cam contact",
        "tests/test_physics.py -k montecarlo",
    ),
    (
        "tolerance/allocation.py",
        'q = percentile if sense == "max" else 100.0 - percentile',
        "q = percentile",
        "allocation uses the upper percentile for min checks",
        "tests/test_physics.py::test_allocation_min_loaded_rollers_uses_lower_percentile",
    ),
    (
        "run/stages_forces.py",
        "        psi_contact_limit=psi_limit,\n",
        "",
        "forces ignore the trimmed tips of an allowed undercut",
        "tests/test_physics.py::test_trimmed_tips_carry_nothing",
    ),
    (
        "geometry/deviations.py",
        "            or self.profile_deviation is not None\n        )\n\n    def slot_errors",
        "        )\n\n    def slot_errors",
        "periodicity shortcut taken with a profile deviation",
        "tests/test_physics.py -k shortcut",
    ),
    (
        "run/scene.py",
        "        if not math.isfinite(v):\n            bounded",
        "        if False:\n            bounded",
        "NaN/inf let through every float key",
        "tests/test_gates.py -k non_finite",
    ),
    (
        "mechanics/contact.py",
        "VALIDITY_KNEE = 0.99",
        "VALIDITY_KNEE = 0.5",
        "contact law replaced by its tangent from 0.5 of the validity limit",
        "tests/test_physics.py -k exact_circle_overlap",
    ),
    (
        "geometry/design.py",
        "L = float(self.cam_radius) + float(self.roller_radius)",
        "L = float(self.cam_radius)",
        "collision limit with Rj for L",
        "tests/test_physics.py -k collision",
    ),
    (
        "export/dxf.py",
        '    tmp = path.with_name(path.name + ".part")\n    _pin_class_order(doc)\n    with _fixed_metadata():\n        doc.saveas(tmp)\n    tmp.replace(path)',
        "    _pin_class_order(doc)\n    with _fixed_metadata():\n        doc.saveas(path)",
        "DXF writer not atomic",
        "tests/test_gates.py -k killed",
    ),
    (
        "export/files.py",
        "    fd, tmp = tempfile.mkstemp(",
        "    path.write_text(text, encoding='utf-8')\n    return path\n    fd, tmp = tempfile.mkstemp(",
        "JSON/CSV writer writes the target in place (not atomic)",
        "tests/test_gates.py -k killed",
    ),
    (
        "mechanics/solver_geometry.py",
        "k_gear = -k_locus / (1.0 + r * k_locus)",
        "k_gear = k_locus / (1.0 + r * k_locus)",
        "gear curvature sign flipped (concave <-> convex)",
        "tests/test_solver.py -k independent",
    ),
    (
        "mechanics/solver_geometry.py",
        "k_gear = -k_locus / (1.0 + r * k_locus)",
        "k_gear = -k_locus",
        "gear curvature of the locus, not the working profile",
        "tests/test_solver.py -k independent",
    ),
    (
        "mechanics/solver_geometry.py",
        "e_act = e + errors.eccentricity_error",
        "e_act = e",
        "eccentricity error dropped",
        "tests/test_solver.py -k independent",
    ),
    (
        "mechanics/solver_geometry.py",
        "k_roller=1.0 / (r + dr),",
        "k_roller=1.0 / r + 0.0 * dr,",
        "roller radius error left out of the roller curvature",
        "tests/test_solver.py -k independent",
    ),
    (
        "mechanics/solver_geometry.py",
        "psi + z * delta",
        "psi - z * delta",
        "slot angle error sign",
        "tests/test_solver.py -k independent",
    ),
    (
        "mechanics/solver_geometry.py",
        "g_n = g_n + np.asarray(errors.profile_deviation(t_abs), dtype=float)",
        "g_n = g_n - np.asarray(errors.profile_deviation(t_abs), dtype=float)",
        "profile deviation sign (material added = clearance)",
        "tests/test_solver.py -k independent",
    ),
    (
        "mechanics/contact.py",
        "return 2.0 * np.sqrt(force / np.asarray(u_per_force, dtype=float)) / (np.pi * length)",
        "return 4.0 * np.sqrt(force / np.asarray(u_per_force, dtype=float)) / (np.pi * length)",
        "Hertz pressure 4F/(pi b l)",
        "tests/test_physics.py -k by_hand",
    ),
    (
        "tolerance/checks.py",
        '"passed": bool(p <= allowed)',
        '"passed": True',
        "Monte Carlo gate never fails",
        "tests/test_gates.py -k gate",
    ),
    (
        "run/console.py",
        '"roller": int(k) + 1,',
        '"roller": int(k),',
        "console rollers numbered from 0",
        "tests/test_gates.py -k console",
    ),
    (
        "run/console.py",
        "best = max(CONTACTS, key=lambda c: float(pressures[c].max()))",
        'best = max(("cam", "slot"), key=lambda c: float(pressures[c].max()))',
        "console pressure peak ignores the gear",
        "tests/test_gates.py -k console or knife",
    ),
    (
        "run/console.py",
        "        if tip < MIN_TIP_RADIUS_MM:",
        "        if tip < 0.01:",
        "tip-radius warning at 0.01 mm instead of 0.1",
        "tests/test_gates.py -k knife",
    ),
    (
        "mechanics/solver.py",
        "a = np.where(g.loadable, g.advance, 0.0)",
        "a = np.where(g.loadable, -g.advance, 0.0)",
        "lost motion with the advance's sign flipped",
        "tests/test_physics.py::test_backlash_in_arcmin_against_hand_calculation",
    ),
    (
        "run/stages_forces.py",
        "float(res.backlash.max() * ARCMIN_PER_RAD)",
        "float(res.backlash.min() * ARCMIN_PER_RAD)",
        "lost-motion check takes the smallest position, not the largest",
        "tests/test_physics.py::test_backlash_in_arcmin_against_hand_calculation",
    ),
    (
        "mechanics/solver_geometry.py",
        "return g_j + rho_n * g_n - np.abs(rho_s) * clearance_slot, dr",
        "return g_j + rho_n * g_n, dr",
        "slot clearance of an undersize roller dropped",
        "tests/test_physics.py::test_backlash_in_arcmin_against_hand_calculation",
    ),
    (
        "mechanics/reference.py",
        "k_gear = -k_loc / (1.0 + r * k_loc)",
        "k_gear = k_loc / (1.0 + r * k_loc)",
        "(reference) gear curvature sign flipped: the reference itself is checked",
        "tests/test_solver.py -k independent",
    ),
    (
        "run/console.py",
        "PRESSURE_BOUND_MPA = 4000.0",
        "PRESSURE_BOUND_MPA = 40000.0",
        "material bound 40 GPa: no warning for 18-38 GPa",
        "tests/test_gates.py -k gigapascal or knife",
    ),
    (
        "tolerance/montecarlo.py",
        "        load_share=load_share,\n        psi_contact_limit=psi_limit,\n    )\n    block",
        "        load_share=load_share,\n    )\n    block",
        "Monte Carlo ignores the trimmed tooth tips (bug found and fixed)",
        "tests/test_physics.py -k trimmed_tips_equals",
    ),
    (
        "tolerance/allocation.py",
        "            base_errors=base_errors,\n            psi_contact_limit",
        "            psi_contact_limit",
        "allocation drops the scene's [errors] (bug found and fixed)",
        "tests/test_physics.py -k keeps_the_scenes",
    ),
    (
        "mechanics/solver_geometry.py",
        "t_abs = phi[:, None] / z + theta[None, :]",
        "t_abs = phi[:, None] + theta[None, :]",
        "profile deviation read at the crank angle, not the roller's polar angle",
        "tests/test_solver.py -k independent",
    ),
    (
        "mechanics/solver_geometry.py",
        "rho_s=-rho_s,",
        "rho_s=rho_s,",
        "slot force reported with the wrong sign",
        "tests/test_solver.py",
    ),
    (
        "geometry/design.py",
        "return self.young_modulus / (2.0 * (1.0 - self.poisson_ratio**2))",
        "return self.young_modulus / (1.0 - self.poisson_ratio**2)",
        "contact modulus E' of one body, not of the pair",
        "tests/test_solver.py -k independent",
    ),
    (
        "export/measured_io.py",
        "exag = working.points(tt) - exaggeration",
        "exag = working.points(tt) + exaggeration",
        "exaggerated deviation drawn on the wrong side",
        "tests/test_measured.py -k round_trip",
    ),
    (
        "mechanics/windup.py",
        "return design.tooth_count * np.asarray(output_angles, dtype=float)",
        "return design.roller_count * np.asarray(output_angles, dtype=float)",
        "windup: output angle mapped to crank angle (z + 1) x instead of z x",
        "tests/test_datasheet.py::test_output_angle_maps_to_crank_angle_z_x",
    ),
    (
        "mechanics/windup.py",
        "return -self.load_share * float(output_torque) / self._ratio",
        "return self.load_share * float(output_torque) / self._ratio",
        "windup: cam moment with the output torque's sign (T = +(z+1) M)",
        "tests/test_datasheet.py::test_windup_is_minus_tau_over_z_plus_1_of_the_solver",
    ),
    (
        "mechanics/windup.py",
        "return -self.load_share * float(output_torque) / self._ratio",
        "return -float(output_torque) / self._ratio",
        "windup: load share of the modelled cam dropped",
        "tests/test_datasheet.py::test_rigidity_against_the_linear_contact_closed_form",
    ),
    (
        "mechanics/windup.py",
        "theta[sl] = -tau / self._ratio",
        "theta[sl] = -tau",
        "windup: cam rotation not divided by z + 1",
        "tests/test_datasheet.py::test_reciprocity_crank_locked_windup_is_cam_rotation_over_z_plus_1",
    ),
    (
        "mechanics/windup.py",
        "lo, hi = -fwd / self._ratio, -rev / self._ratio",
        "lo, hi = -rev / self._ratio, -fwd / self._ratio",
        "windup: ends of the free rotation swapped (theta(0+) < theta(0-))",
        "tests/test_datasheet.py::test_backlash_equals_the_exact_free_rotation_of_the_clearance_geometry",
    ),
    (
        "mechanics/windup.py",
        "return float(rigidity_Nm_per_arcmin) * NMM_PER_NM * ARCMIN_PER_RAD",
        "return float(rigidity_Nm_per_arcmin) * ARCMIN_PER_RAD",
        "series rigidity: N*m taken as N*mm",
        "tests/test_datasheet.py::test_series_compliance_adds_T_over_K",
    ),
    (
        "mechanics/windup.py",
        "m = (z * k) % modulus",
        "m = k % modulus",
        "transmission error: periodicity class without the factor z",
        "tests/test_datasheet.py::test_revolution_classes_equal_solving_every_position",
    ),
    (
        "mechanics/datasheet.py",
        "return self.at(b) - self.at(-b)",
        "return self.at(b) - self.at(0.0)",
        "lost motion from 0+ to +b T_R, not across the band",
        "tests/test_datasheet.py::test_two_micrometre_undersize_backlash_and_lost_motion_by_hand",
    ),
    (
        "mechanics/datasheet.py",
        "dT = (tb - ta) * self.spec.rated_torque / NMM_PER_NM",
        "dT = (tb - ta) * self.spec.rated_torque",
        "rigidity in N*mm/arcmin labelled N*m/arcmin",
        "tests/test_datasheet.py::test_rigidity_against_the_linear_contact_closed_form",
    ),
    (
        "mechanics/datasheet.py",
        '"K1": self._rigidity(0.0, ta, False),',
        '"K1": self._rigidity(-0.0, ta, False),',
        "K1 measured from theta(0-): the backlash counted as windup",
        "tests/test_datasheet.py::test_figures_are_reproducible_by_hand_from_the_csv_files",
    ),
    (
        "mechanics/datasheet.py",
        "te_forward=wt.theta(-T_te)[index],",
        "te_forward=wt.theta(T_te)[index],",
        "transmission error: forward read at +T_TE (both curves the reverse one)",
        "tests/test_datasheet.py::test_one_roller_oversize_transmission_error_has_a_feature_each_pass",
    ),
    (
        "mechanics/datasheet.py",
        '"torsional_rigidity_Nm_per_arcmin": float(self.rigidity().min()),',
        '"torsional_rigidity_Nm_per_arcmin": float(self.rigidity(contact_only=True).min()),',
        "rigidity check judged on the contacts alone (series rigidity ignored)",
        "tests/test_datasheet.py::test_checks_console_and_report_show_the_datasheet",
    ),
    (
        "run/stages_datasheet.py",
        "return scene.design.roller_count * abs(float(scene.load.input_torque))",
        "return scene.design.tooth_count * abs(float(scene.load.input_torque))",
        "default T_R = z M0 instead of (z + 1) M0",
        "tests/test_datasheet.py::test_figures_are_reproducible_by_hand_from_the_csv_files",
    ),
    (
        "run/stages_datasheet.py",
        "return float(given) * NMM_PER_NM",
        "return float(given)",
        "[datasheet] rated_torque_Nm read as N*mm",
        "tests/test_datasheet.py::test_datasheet_needs_a_rated_torque_and_no_montecarlo_gate",
    ),
    (
        "export/datasheet_io.py",
        "ds.te_forward * ARCSEC_PER_RAD,",
        "ds.te_forward * ARCMIN_PER_RAD,",
        "transmission_error.csv forward column in arcmin, labelled arcsec",
        "tests/test_datasheet.py::test_figures_are_reproducible_by_hand_from_the_csv_files",
    ),
    (
        "tolerance/checks.py",
        '"min_torsional_rigidity_Nm_per_arcmin": ("torsional_rigidity_Nm_per_arcmin", "min"),',
        '"min_torsional_rigidity_Nm_per_arcmin": ("torsional_rigidity_Nm_per_arcmin", "max"),',
        "rigidity limit bounds from above",
        "tests/test_datasheet.py::test_checks_console_and_report_show_the_datasheet",
    ),
    (
        "run/scene_text.py",
        'if "max_lost_motion_arcmin" in data.get("checks", {}) and "datasheet" not in data:',
        'if "max_lost_motion_arcmin" in data.get("checks", {}) and "datasheet" in data:',
        "old lost-motion key: the warning never reaches an old scene",
        "tests/test_datasheet.py::test_old_lost_motion_key_keeps_working_with_one_warning",
    ),
    (
        "run/scene_schema.py",
        '            0.03,\n            "lost motion at +- this share of T_R',
        '            0.04,\n            "lost motion at +- this share of T_R',
        "lost-motion band default 4 % (strain-wave) instead of 3 % (RV)",
        "tests/test_datasheet.py::test_figures_are_reproducible_by_hand_from_the_csv_files",
    ),
]
only = [int(x) for x in sys.argv[1:]]
env = dict(os.environ, PYTHONPATH=str(WT))
for i, (f, old, new, what, tests) in enumerate(M):
    if only and i not in only:
        continue
    p = WT / "corr_cad" / f
    src = p.read_text()
    assert src.count(old) >= 1, (i, old)
    p.write_text(src.replace(old, new, 1))
    try:
        r = subprocess.run(
            [
                "nice",
                sys.executable,
                "-m",
                "pytest",
                "-x",
                "-q",
                "-p",
                "no:cacheprovider",
                *tests.split(" ", 1)[0:1],
                *(["-k", tests.split(" -k ", 1)[1]] if " -k " in tests else []),
            ],
            cwd=WT,
            env=env,
            capture_output=True,
            text=True,
        )
        last = r.stdout.strip().splitlines()[-1] if r.stdout.strip() else r.stderr[-200:]
        state = "CAUGHT" if r.returncode != 0 else "MISSED"
        failed = [x for x in r.stdout.splitlines() if x.startswith("FAILED")]
        print(f"{i}|{state}|{f}|{what}|{tests}|{failed[0][7:90] if failed else last}", flush=True)
    finally:
        p.write_text(src)
