"""Per-tooth inspection of a measured inner gear, and a fit to the design family.

Definitions (in the spirit of ISO 1328-1, adapted to this profile)
-----------------------------------------------------------------
The measured points are first registered to the exact working profile as a
whole (best-fit rotation and centre, ``measured.register``). Each point then
has a normal deviation ``f`` from the nominal, + where material was added
(the point lies in the opening), and the roller-centre parameter ``t`` of
its foot point. Tooth space ``k`` (1-based) is the valley centred at polar
angle ``(k - 1) 360/z`` deg; it owns the points with ``t`` within half a
pitch of that centre whose ``|psi| = |z (t - t_k)|`` is within the
evaluated range.

* ``profile_deviation_mm``: range (max - min) of ``f`` over the tooth (the
  ISO total profile deviation, measured normal to the profile rather than
  along a line of action). ``profile_tolerance`` is a half-band: a tooth
  passes when every ``|f| <= profile_tolerance``.
* ``position_arcsec``: the tooth's own best-fit rotation ``delta_k`` (least
  squares on ``f``; + = turned towards growing polar angle, i.e. clockwise
  seen from +z); relative to the whole-gear fit, so the positions average
  about zero.
* ``form_deviation_mm``: range of ``f`` after removing ``delta_k`` (the ISO
  form deviation, with rotation as the only removed motion).
* ``single_pitch_arcsec``: ``delta_k - delta_(k-1)`` (tooth 1 follows
  tooth z); ``cumulative_pitch_arcsec``: ``delta_k - delta_1``. The
  cumulative pitch over any span is ``max delta - min delta``.
* ``runout_mm``: each tooth space's best-fit radial shift ``rho_k`` (fitted
  jointly with a rotation, on the points turned by the whole-gear rotation
  only, i.e. about the CMM's origin, which must be the gear's datum axis) -
  the adaptation of a ball probe's radial position. The gear's runout is
  ``max rho - min rho``; the CSV gives ``rho_k - min rho``.

Pure numpy/scipy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize

from corr_cad.errors import ProfileError
from corr_cad.geometry import kinematics as kin
from corr_cad.geometry.profile import ProfileCurve
from corr_cad.geometry.projection import signed_normal_distance

__all__ = [
    "ARCSEC_PER_RAD",
    "LIMITS",
    "ToothReport",
    "InspectionResult",
    "inspect_teeth",
    "tooth_verdicts",
    "evaluate_limits",
    "fit_design_family",
]

ARCSEC_PER_RAD = 180.0 * 3600.0 / math.pi

#: ``[inspection]`` limit keys and what each limits.
LIMITS = (
    "profile_tolerance",
    "position_tolerance_arcsec",
    "single_pitch_tolerance_arcsec",
    "cumulative_pitch_tolerance_arcsec",
    "runout_tolerance",
)


@dataclass(frozen=True)
class ToothReport:
    tooth: int
    points: int
    profile_deviation_mm: float
    profile_min_mm: float
    profile_max_mm: float
    form_deviation_mm: float
    position_arcsec: float
    single_pitch_arcsec: float
    cumulative_pitch_arcsec: float
    runout_mm: float
    radial_shift_mm: float


@dataclass(frozen=True)
class InspectionResult:
    teeth: tuple[ToothReport, ...]
    cumulative_pitch_total_arcsec: float
    cumulative_pitch_span: tuple[int, int]
    runout_mm: float
    #: per-point data for the chart: polar angle t (rad), deviation (mm), tooth
    t: np.ndarray = field(repr=False, default=None)
    deviation: np.ndarray = field(repr=False, default=None)
    tooth_of_point: np.ndarray = field(repr=False, default=None)

    def column(self, name: str) -> np.ndarray:
        return np.array([getattr(r, name) for r in self.teeth])


def _dev(curve: ProfileCurve, pts: np.ndarray, seed=None):
    d, t = signed_normal_distance(curve, pts, seed)
    return -d, t  # + = material added (into the opening)


def inspect_teeth(
    working: ProfileCurve,
    placed: np.ndarray,
    datum: np.ndarray,
    evaluation_psi_deg: float = 180.0,
) -> InspectionResult:
    """Per-tooth deviations of measured points.

    ``placed`` (n, 2): the points after the whole-gear registration;
    ``datum`` (n, 2): the same points turned by the registration's rotation
    only (centre as measured), for the runout.
    """
    z = working.tooth_count
    pitch = 2 * math.pi / z
    f, t = _dev(working, placed)
    k0 = np.mod(np.round(t / pitch).astype(int), z)
    psi = z * (t - np.round(t / pitch) * pitch)
    use = np.abs(psi) <= math.radians(evaluation_psi_deg) + 1e-12
    reports = []
    pos = np.zeros(z)
    rho = np.zeros(z)
    stats = []
    for k in range(z):
        sel = np.flatnonzero(use & (k0 == k))
        if sel.size < 3:
            raise ProfileError(
                f"[inspection] evaluation_psi_deg = {evaluation_psi_deg:g}: tooth space {k + 1} "
                f"has {sel.size} measured points in the evaluated range; need at least 3"
            )
        q, fk, tk = placed[sel], f[sel], t[sel]
        delta = 0.0
        for _ in range(4):
            qq = kin.rotate_by_polar_angle(q, -delta)
            fr, tk = _dev(working, qq, tk)
            n = working.normals(tk)
            g = n[:, 0] * qq[:, 1] - n[:, 1] * qq[:, 0]
            step = -float(np.dot(fr, g) / np.dot(g, g))
            delta += step
            if abs(step) < 1e-14:
                break
        form_res, _ = _dev(working, kin.rotate_by_polar_angle(q, -delta), tk)
        # Runout: radial shift of the tooth space (with a rotation) about the datum axis.
        qd = datum[sel]
        fd, td = _dev(working, qd, t[sel])
        n = working.normals(td)
        u = kin.unit_radial(np.array([k * pitch]))[0]
        a = -(n @ u)
        g = n[:, 0] * qd[:, 1] - n[:, 1] * qd[:, 0]
        # f = a rho - g delta_d: least squares for (rho, delta_d)
        sol, *_ = np.linalg.lstsq(np.stack([a, -g], axis=1), fd, rcond=None)
        rho[k] = sol[0]
        pos[k] = delta
        stats.append((sel.size, fk.min(), fk.max(), np.ptp(form_res)))
    pos_as = pos * ARCSEC_PER_RAD
    single = pos_as - np.roll(pos_as, 1)
    cum = pos_as - pos_as[0]
    for k in range(z):
        n_pts, fmin, fmax, form = stats[k]
        reports.append(
            ToothReport(
                k + 1,
                int(n_pts),
                float(fmax - fmin),
                float(fmin),
                float(fmax),
                float(form),
                float(pos_as[k]),
                float(single[k]),
                float(cum[k]),
                float(rho[k] - rho.min()),
                float(rho[k]),
            )
        )
    i_lo, i_hi = int(np.argmin(pos_as)), int(np.argmax(pos_as))
    return InspectionResult(
        tuple(reports),
        float(pos_as.max() - pos_as.min()),
        (i_lo + 1, i_hi + 1),
        float(rho.max() - rho.min()),
        t,
        f,
        np.where(use, k0 + 1, 0),
    )


def _within_best_band(values: np.ndarray, width: float) -> np.ndarray:
    """Which values lie in the band ``[a, a + width]`` that holds the most of them.

    Ties go to the band whose centre is nearest the mean. All values pass
    exactly when ``max - min <= width`` (the band starting at the minimum).
    """
    order = np.argsort(values, kind="stable")
    v = values[order]
    best, best_key = 0, None
    for i in range(len(v)):
        j = int(np.searchsorted(v - v[i], width, side="right"))  # v[j-1] - v[i] <= width
        key = (-(j - i), abs(v[i] + 0.5 * width - float(values.mean())))
        if best_key is None or key < best_key:
            best, best_key = i, key
    inside = np.zeros(len(v), dtype=bool)
    inside[order[(v - v[best] >= 0.0) & (v - v[best] <= width)]] = True
    return inside


def tooth_verdicts(res: InspectionResult, limits: dict) -> dict[str, np.ndarray]:
    """Pass (True) or fail of every tooth space for each limit that is set, (z,) bool.

    The one place a tooth is judged: ``inspection.csv``, ``inspection.json``
    (``failing_teeth``), the console and ``inspection.png`` all read it.

    * ``profile_tolerance``: every ``|f|`` of the tooth within the half-band;
    * ``position_tolerance_arcsec``, ``single_pitch_tolerance_arcsec``: the
      tooth's ``|position|``, ``|single pitch|`` within the limit;
    * ``cumulative_pitch_tolerance_arcsec``: the tooth's position lies in the
      band, as wide as the limit, that holds the most tooth positions (the
      teeth outside it are the ones to rework);
    * ``runout_tolerance``: likewise for the radial positions.

    The gear passes a limit exactly when every tooth passes it: the band holds
    all positions (radial positions) exactly when their span, the cumulative
    pitch (runout), is within the limit.
    """
    pos = res.column("position_arcsec")
    prof = np.maximum(np.abs(res.column("profile_min_mm")), np.abs(res.column("profile_max_mm")))
    judge = {
        "profile_tolerance": lambda lim: prof <= lim,
        "position_tolerance_arcsec": lambda lim: np.abs(pos) <= lim,
        "single_pitch_tolerance_arcsec": lambda lim: (
            np.abs(res.column("single_pitch_arcsec")) <= lim
        ),
        "cumulative_pitch_tolerance_arcsec": lambda lim: _within_best_band(pos, lim),
        "runout_tolerance": lambda lim: _within_best_band(res.column("radial_shift_mm"), lim),
    }
    return {k: judge[k](limits[k]) for k in LIMITS if limits.get(k) is not None}


def evaluate_limits(res: InspectionResult, limits: dict) -> dict:
    """Pass/fail per given limit, with the worst tooth, its value and the failing teeth."""
    out = {}
    prof = np.maximum(np.abs(res.column("profile_min_mm")), np.abs(res.column("profile_max_mm")))
    per_tooth = {
        "profile_tolerance": (prof, "mm", "largest |profile deviation| from nominal"),
        "position_tolerance_arcsec": (
            np.abs(res.column("position_arcsec")),
            "arcsec",
            "|tooth position|",
        ),
        "single_pitch_tolerance_arcsec": (
            np.abs(res.column("single_pitch_arcsec")),
            "arcsec",
            "|single pitch deviation|",
        ),
    }
    passes = tooth_verdicts(res, limits)
    for key, ok in passes.items():
        lim = limits[key]
        bad = [int(j + 1) for j in np.flatnonzero(~ok)]
        if key in per_tooth:
            vals, unit, what = per_tooth[key]
            i = int(np.argmax(vals))
            out[key] = {
                "limit": lim,
                "value": float(vals[i]),
                "tooth": i + 1,
                "unit": unit,
                "what": what,
            }
        elif key == "cumulative_pitch_tolerance_arcsec":
            out[key] = {
                "limit": lim,
                "value": res.cumulative_pitch_total_arcsec,
                "tooth": res.cumulative_pitch_span[1],
                "span_teeth": list(res.cumulative_pitch_span),
                "unit": "arcsec",
                "what": "cumulative pitch over any span",
            }
        else:
            rr = res.column("runout_mm")
            out[key] = {
                "limit": lim,
                "value": res.runout_mm,
                "tooth": int(np.argmax(rr)) + 1,
                "unit": "mm",
                "what": "runout of the tooth spaces",
            }
        out[key]["failing_teeth"] = bad
        out[key]["passed"] = not bad
    return out


#: Central-difference steps of the fit's parameters (e, L in mm; phase in rad; centre in mm).
_JACOBIAN_STEPS = (1e-6, 1e-6, 1e-8, 1e-6, 1e-6)


def _inverse_normal_matrix(J: np.ndarray, resid, x: np.ndarray, seed: dict) -> np.ndarray:
    """``(J^T J)^-1`` for the fit's uncertainty.

    The solver's last forward-difference Jacobian can come back with a zero
    column at a near-exact fit (a CMM file written to 1e-9 mm); it is then
    recomputed at the solution by central differences with fixed steps.
    """
    for attempt in range(2):
        if attempt:
            cols = []
            for j, h in enumerate(_JACOBIAN_STEPS):
                step = np.zeros_like(x)
                step[j] = h
                seed["t"] = None
                up = resid(x + step)
                seed["t"] = None
                cols.append((up - resid(x - step)) / (2.0 * h))
            J = np.stack(cols, axis=1)
        JtJ = J.T @ J
        if np.all(np.isfinite(JtJ)) and np.linalg.matrix_rank(JtJ) == JtJ.shape[0]:
            return np.linalg.inv(JtJ)
    raise ProfileError(
        "the measured points do not determine the eccentricity, link length, phase and "
        "centre of the fit; measure every tooth flank, e.g. 20 points per tooth"
    )


def fit_design_family(working: ProfileCurve, points: np.ndarray, max_points: int = 4000) -> dict:
    """Best-fit eccentricity, link length ``L``, phase and centre for measured points.

    Model: the working profile of ``(z, e, L, r)`` (``r`` as designed),
    turned by ``phase`` and moved to ``centre``; residual the normal distance
    of each point. Uncertainty: ``sigma^2 (J^T J)^-1`` with ``sigma^2`` the
    residual variance (``n - 5`` degrees of freedom) and ``J`` the Jacobian
    at the solution.
    """
    z, r = working.tooth_count, working.offset
    e0, L0 = working.eccentricity, working.link_length
    pts = np.asarray(points, dtype=float)[:: max(1, len(points) // max_points)]
    seed = {"t": None}

    def resid(x):
        e, L, ph, cx, cy = x
        q = kin.rotate_by_polar_angle(pts - np.array([cx, cy]), -ph)
        d, t = signed_normal_distance(ProfileCurve(z, e, L, r), q, seed["t"])
        if seed["t"] is None:
            seed["t"] = t
        return d

    base = resid(np.array([e0, L0, 0.0, 0.0, 0.0]))
    seed["t"] = None
    # coarse phase search over one pitch (the profile repeats every pitch)
    cands = np.linspace(-math.pi / z, math.pi / z, 25, endpoint=False)
    rms = []
    for c in cands:
        seed["t"] = None
        rms.append(float(np.sqrt(np.mean(resid(np.array([e0, L0, c, 0.0, 0.0])) ** 2))))
    ph0 = float(cands[int(np.argmin(rms))])
    seed["t"] = None
    resid(np.array([e0, L0, ph0, 0.0, 0.0]))
    fit = optimize.least_squares(
        resid,
        [e0, L0, ph0, 0.0, 0.0],
        x_scale=[1e-3, 1e-3, 1e-5, 1e-3, 1e-3],
        diff_step=1e-7,
        xtol=1e-14,
        ftol=1e-14,
        gtol=1e-14,
    )
    seed["t"] = None
    res = resid(fit.x)
    n, p = len(res), 5
    s2 = float(np.sum(res**2) / (n - p))
    cov = s2 * _inverse_normal_matrix(fit.jac, resid, fit.x, seed)
    sig = np.sqrt(np.diag(cov))
    e, L, ph, cx, cy = (float(v) for v in fit.x)
    return {
        "model": "working profile of (z, e, L, r) turned by phase, centred at centre; "
        "r as designed",
        "eccentricity_mm": e,
        "eccentricity_sigma_mm": float(sig[0]),
        "eccentricity_error_mm": e - e0,
        "link_length_mm": L,
        "link_length_sigma_mm": float(sig[1]),
        "link_length_error_mm": L - L0,
        "phase_deg": math.degrees(ph),
        "phase_sigma_deg": math.degrees(sig[2]),
        "centre_mm": [cx, cy],
        "centre_sigma_mm": [float(sig[3]), float(sig[4])],
        "points_used": int(n),
        "rms_residual_mm": float(np.sqrt(np.mean(res**2))),
        "rms_nominal_mm": float(np.sqrt(np.mean(base**2))),
        "correlation": np.round(cov / np.outer(sig, sig), 6).tolist(),
        "success": bool(fit.success),
    }
