"""What keeps compiling the kernels cheap: one type signature per kernel, no slice
assignment in a compiled body (``docs/accuracy-and-speed.md``, "Compiling the kernels")."""

from __future__ import annotations

import ast
import os
import subprocess
import sys

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


def _jitted(module: str):
    tree = ast.parse(source(module).read_text())
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and any(
            isinstance(d, ast.Name) and d.id in ("_jit", "_jit_inner") for d in node.decorator_list
        ):
            yield node


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
