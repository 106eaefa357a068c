"""What keeps compiling the kernels cheap: one type signature per kernel, no slice
assignment in a compiled body (``docs/accuracy-and-speed.md``, "Compiling the kernels")."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

from corr_cad.run.warmup import source

KERNELS = (
    "mc_kernel",
    "mc_windup_kernel",
    "free_play",
    "drive_laws",
    "drive_kernel",
    "drive_centre",
    "coupling_kernel",
    "coupling_newton",
)
#: Every module with compiled kernels.
ALL_KERNELS = (*KERNELS, "drive_rigid")
ROOT = Path(__file__).resolve().parents[1]


def _jitted(module: str, decorators=("_jit", "_jit_inner")):
    tree = ast.parse(source(module).read_text())
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and any(
            isinstance(d, ast.Name) and d.id in decorators for d in node.decorator_list
        ):
            yield node


def _python_names() -> set[str]:
    """Every name and attribute the Python code of the package and the tests uses outside
    compiled functions and imports (a kernel Python calls is among them)."""
    names: set[str] = set()

    def visit(node) -> None:
        if isinstance(node, ast.FunctionDef) and any(
            isinstance(d, ast.Name) and d.id.startswith("_jit") for d in node.decorator_list
        ):
            return
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            return
        if isinstance(node, ast.Name):
            names.add(node.id)
        if isinstance(node, ast.Attribute):
            names.add(node.attr)
        for child in ast.iter_child_nodes(node):
            visit(child)

    for path in (*(ROOT / "corr_cad").rglob("*.py"), *(ROOT / "tests").rglob("*.py")):
        visit(ast.parse(path.read_text()))
    return names


@pytest.mark.parametrize("module", ALL_KERNELS)
def test_a_kernel_only_compiled_code_calls_has_no_python_wrapper(module):
    """A helper that no Python code calls is ``@_jit_inner``: numba then compiles no
    wrapper for Python's calls (about 0.1 s each; the drive's and the free play's twenty
    helpers made a fifth of their compile, ``docs/accuracy-and-speed.md``)."""
    from corr_cad.run.warmup import _UNUSED  # kernels no stage calls: left as they are

    used = {*_python_names(), *_UNUSED.get(module, ())}
    wrapped = [fn.name for fn in _jitted(module, ("_jit",)) if fn.name not in used]
    assert not wrapped, f"{module}: {wrapped} only compiled code calls: decorate with @_jit_inner"


def test_a_python_call_of_a_helper_compiled_for_compiled_callers_raises():
    """Without its wrapper numba would jump through a null pointer and the process die."""
    from corr_cad.mechanics.drive.drive_laws import _palmgren

    with pytest.raises(TypeError, match="@_jit_inner.*decorate it with @_jit"):
        _palmgren(1e-3, 1e-5)


def _slice_targets(fn: ast.FunctionDef) -> list[int]:
    """Lines of ``a[...:...] = ...`` (a tuple of targets included) in ``fn``'s body."""
    lines = []
    for node in ast.walk(fn):
        targets = node.targets if isinstance(node, ast.Assign) else []
        if isinstance(node, ast.AugAssign):
            targets = [node.target]
        for t in targets:
            for sub in ast.walk(t):
                if isinstance(sub, ast.Subscript) and any(
                    isinstance(s, ast.Slice) for s in ast.walk(sub.slice)
                ):
                    lines.append(node.lineno)
    return lines


@pytest.mark.parametrize("module", KERNELS)
def test_no_compiled_kernel_assigns_to_a_slice(module):
    """An array slice assignment costs numba and LLVM about 0.3 s of compile each (the
    bearing Newton's twenty made half of the drive kernels' compile); the kernels copy
    their small work arrays by loops (``drive_kernel._copy1``, ``_copy2``)."""
    found = {fn.name: _slice_targets(fn) for fn in _jitted(module)}
    assert found, module
    assert not {k: v for k, v in found.items() if v}, found


@pytest.mark.slow
def test_every_kernel_compiles_once_from_an_empty_cache(tmp_path):
    """From an empty cache the warm-up's paper and drive runs and the compiled inversion
    leave every compiled function of the Monte Carlo and drive kernels with one type
    signature (a constant bool argument compiled ``mc_kernel._evaluate`` once per value; a
    roller table sliced per call gave ``drive_laws._invert_one`` a second layout)."""
    code = (
        "import numba, numpy as np\n"
        "from corr_cad.run import warmup\n"
        "warmup._paper_kernels(False); warmup._drive_kernels(); warmup._bodies_kernels()\n"
        "from corr_cad.geometry.design import GearDesign\n"
        "from corr_cad.mechanics.drive.drive_kernel import CompiledDriveSolver, CompiledInverse\n"
        "from corr_cad.mechanics.row.solver_geometry import cycle_angles\n"
        "s = CompiledDriveSolver(GearDesign(), cycle_angles(4))\n"
        "shape = s.geo_joined.gap.shape\n"
        "CompiledInverse(s.comp, shape)(np.full(shape, 1e-3), np.full(shape, 10.0))\n"
        "import importlib\n"
        "rooms = {'mc_kernel': 'row', 'drive_laws': 'drive', 'drive_kernel': 'drive',\n"
        "         'drive_centre': 'drive', 'coupling_kernel': 'drive',\n"
        "         'coupling_newton': 'drive'}\n"
        "for m, room in rooms.items():\n"
        "    mod = importlib.import_module(f'corr_cad.mechanics.{room}.{m}')\n"
        "    for k, v in sorted(vars(mod).items()):\n"
        "        jit = isinstance(v, numba.core.registry.CPUDispatcher)\n"
        "        if jit and v.__module__ == mod.__name__:\n"
        "            print(m, k, len(v.signatures))\n"
    )
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    rows = [line.split() for line in out.stdout.strip().splitlines()]
    names = {f"{m}.{k}" for m, k, _ in rows}
    assert {"mc_kernel._evaluate", "drive_laws._invert_one", "drive_kernel._invert"} <= names
    assert {"coupling_kernel.influence_kernel", "coupling_newton._newton"} <= names
    # The tests' own readers of the tables (``coupling_kernel._ring_at``) no run compiles.
    from corr_cad.run.warmup import _UNUSED

    assert all(n == "1" or (n == "0" and k in _UNUSED.get(m, ())) for m, k, n in rows), out.stdout


#: Every warm-up group's kernels on seeded inputs: sha256 of their raw outputs' bits.
_BITS = """
import hashlib
import numpy as np
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.crank.bearing import EccentricBearing
from corr_cad.mechanics.datasheet import DatasheetSpec
from corr_cad.mechanics.drive.drive import DriveSolver
from corr_cad.mechanics.row.solver_geometry import cycle_angles
from corr_cad.tolerance.mc_datasheet import DatasheetMC
from corr_cad.tolerance.montecarlo import Distribution, monte_carlo

h = hashlib.sha256()
def add(r):
    for k in sorted(r.metrics):
        h.update(np.asarray(r.metrics[k], dtype=float).tobytes())
design = GearDesign()
tol = {"roller_radius": Distribution("uniform", 0.002),
       "cam_radius": Distribution("uniform", 0.003),
       "cam_phase": Distribution("normal", 0.003),
       "eccentricity": Distribution("normal", 0.001)}
base = ManufacturingErrors(cam_phase_error=1e-4)
def sheet(**k):
    return DatasheetMC(DatasheetSpec(rated_torque=26 * 1.1e5), **k)
add(monte_carlo(design, 1.1e5, tol, 24, 7, 36, kernel=True, base_errors=base))
add(monte_carlo(design, 1.1e5, tol, 6, 8, 12, kernel=True, datasheet=sheet()))
for law in ("nonlinear", "palmgren"):
    for clearance in (0.0, 0.005):
        bearing = EccentricBearing(40, 6.0, 12.0, diametral_clearance=clearance)
        drive = {"bearing": bearing, "contact_model": law}
        add(monte_carlo(design, 1.1e5, tol, 6, 9, 12, drive=drive, base_errors=base))
        add(monte_carlo(design, 1.1e5, tol, 3, 10, 8, drive=drive,
                        datasheet=sheet(positions_per_mesh=1)))
        solver = DriveSolver(design, cycle_angles(36), bearing=bearing, contact_model=law)
        for side in solver.free_interval(solve=False):
            h.update(np.asarray(side, dtype=float).tobytes())
print(h.hexdigest())
"""


@pytest.mark.slow
def test_the_kernels_give_the_same_bits_at_numba_s_default_optimisation(tmp_path):
    """The kernels compile at LLVM's level 2 (helpers 1) instead of numba's 3: without
    ``fastmath`` no level reorders floating-point arithmetic, so every output keeps its
    bits (the Monte Carlo's, the datasheet's, the drive's on needles with and without a
    clearance under both laws, the free play's). ``NUMBA_OPT`` set compiles them at it."""
    digests = []
    for level in (None, "3"):
        env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / f"cache-{level}")}
        env.pop("NUMBA_OPT", None)
        if level:
            env["NUMBA_OPT"] = level
        out = subprocess.run(
            [sys.executable, "-c", _BITS], env=env, capture_output=True, text=True, check=True
        )
        digests.append(out.stdout.strip().splitlines()[-1])
    assert digests[0] == digests[1]
