"""The package's layout: layers import downwards only, and nothing imports in a cycle.

Walks every module's ``import`` statements with :mod:`ast` (at module level,
inside functions and under ``TYPE_CHECKING`` alike: an import that only
dodges a cycle at run time still counts). Imports nothing from the package.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "corr_cad"

#: Each top-level module or subpackage and its layer, lowest first. A module
#: may import from its own layer or any lower one, never from a higher one.
LAYERS = {
    "_version": 0,
    "_startup": 0,
    "errors": 0,
    "bounds": 0,
    "figure_text": 0,
    "geometry": 1,
    "mechanics": 2,
    "tolerance": 3,
    "shop": 3,
    "export": 4,
    "run": 5,
    "": 6,  # corr_cad/__init__.py: the public API gathers every layer
    "__main__": 6,
}

#: Inside ``run``: each module at ``run/`` or subpackage of it and its rank,
#: lowest first. A module of ``run`` may import from its own rank or a lower
#: one, never from a higher one; two at one rank never import each other.
RUN_LAYERS = {
    "": 0,  # corr_cad/run/__init__.py
    "interrupts": 0,
    "progress": 0,
    "console": 0,
    "console_datasheet": 0,
    "dask_exec": 0,
    "cli_messages": 0,
    "scene": 1,
    "folder": 1,
    "stages": 2,
    "warmup": 2,
    "pools": 2,
    "budget": 3,
    "pipeline": 4,
    "bench": 5,
    "cli": 6,
}

#: Inside ``mechanics``: each module at ``mechanics/`` or room (subpackage) of it and its
#: rank, lowest first, under the same rule as ``run``'s: the contact laws and ratings on
#: the ground floor, the paper's row, the crankshaft and its bearings, the losses and the
#: first stage on the next, the drive above them, the elastic bodies (reduced to the
#: drive's influence tables) and the figures read off a solved drive on top.
MECHANICS_LAYERS = {
    "": 0,  # corr_cad/mechanics/__init__.py
    "contact": 0,
    "palmgren": 0,
    "life": 0,
    "life_modified": 0,
    "reference": 0,
    "row": 1,
    "crank": 1,
    "losses": 1,
    "gears": 1,
    "drive": 2,
    "binding": 2,
    "bodies": 3,
    "compliance_budget": 3,
    "datasheet": 4,
}

#: Third-party packages only the exporters may import (file formats, drawing).
EXPORT_ONLY = ("ezdxf", "trimesh", "manifold3d", "OCP", "matplotlib", "jinja2")

MAX_LINES = 620


def _modules() -> dict[str, Path]:
    out = {}
    for p in sorted(PKG.rglob("*.py")):
        parts = list(p.relative_to(PKG.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = p
    return out


MODULES = _modules()


def _imports(name: str, path: Path) -> tuple[set[str], set[str]]:
    """(package modules, third-party top-level names) that ``name`` imports."""
    tree = ast.parse(path.read_text())
    base = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    inner, outer = set(), set()
    for node in ast.walk(tree):
        targets: list[str] = []
        if isinstance(node, ast.ImportFrom):
            if node.level:
                b = base[: len(base) - (node.level - 1)]
                mod = ".".join(b + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            targets = [f"{mod}.{a.name}" for a in node.names] + [mod]
        elif isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif (
            isinstance(node, ast.Call)
            and getattr(node.func, "attr", getattr(node.func, "id", None)) == "import_module"
            and node.args
            and isinstance(node.args[0], ast.Constant)
        ):
            arg = node.args[0].value
            targets = [f"corr_cad{arg}" if arg.startswith(".") else arg]
        for t in targets:
            if t.split(".")[0] != "corr_cad":
                outer.add(t.split(".")[0])
                continue
            # the longest prefix that is a module of the package
            parts = t.split(".")
            for k in range(len(parts), 0, -1):
                cand = ".".join(parts[:k])
                if cand in MODULES:
                    if cand != name:
                        inner.add(cand)
                    break
    return inner, outer


GRAPH = {name: _imports(name, path) for name, path in MODULES.items()}


def _layer(mod: str) -> int:
    parts = mod.split(".")
    top = parts[1] if len(parts) > 1 else ""
    return LAYERS[top]


def test_every_module_has_a_layer():
    unknown = sorted({m.split(".")[1] for m in MODULES if "." in m} - set(LAYERS))
    assert not unknown, f"modules outside any layer: {unknown}"


def test_no_upward_import():
    bad = [
        f"{a} (layer {_layer(a)}) imports {b} (layer {_layer(b)})"
        for a, (deps, _) in GRAPH.items()
        for b in sorted(deps)
        if _layer(b) > _layer(a)
    ]
    assert not bad, "upward imports:\n" + "\n".join(bad)


def _part(mod: str, pkg: str) -> str | None:
    """The module or subpackage of ``pkg`` that ``mod`` belongs to, or None outside ``pkg``."""
    parts = mod.split(".")
    if len(parts) < 2 or parts[1] != pkg:
        return None
    return parts[2] if len(parts) > 2 else ""


def _run_part(mod: str) -> str | None:
    """The module or subpackage of ``run`` that ``mod`` belongs to, or None outside ``run``."""
    return _part(mod, "run")


def _against_the_order(pkg: str, layers: dict[str, int]) -> list[str]:
    """Imports inside ``pkg`` against the order of ``layers``: upward, or between two parts
    of one rank above 0."""
    bad = []
    for a, (deps, _) in GRAPH.items():
        pa = _part(a, pkg)
        if pa is None:
            continue
        for b in sorted(deps):
            pb = _part(b, pkg)
            if pb is None or pb == pa:
                continue
            if layers[pb] > layers[pa] or (
                layers[pb] == layers[pa] and pb != "" and layers[pa] > 0
            ):
                bad.append(f"{a} ({pa}, rank {layers[pa]}) imports {b} ({pb}, rank {layers[pb]})")
    return bad


def test_every_module_of_run_has_a_rank():
    unknown = sorted({_run_part(m) for m in MODULES} - {None} - set(RUN_LAYERS))
    assert not unknown, f"modules of run outside any rank: {unknown}"


def test_run_imports_one_way():
    bad = _against_the_order("run", RUN_LAYERS)
    assert not bad, "imports against the order inside run:\n" + "\n".join(bad)


def test_every_module_of_mechanics_has_a_rank():
    unknown = sorted({_part(m, "mechanics") for m in MODULES} - {None} - set(MECHANICS_LAYERS))
    assert not unknown, f"modules of mechanics outside any rank: {unknown}"


def test_mechanics_imports_one_way():
    bad = _against_the_order("mechanics", MECHANICS_LAYERS)
    assert not bad, "imports against the order inside mechanics:\n" + "\n".join(bad)


def test_the_manual_states_the_mechanics_order():
    """docs/development.md's table of the rooms of ``mechanics`` is this file's order."""
    text = (PKG.parent / "docs" / "development.md").read_text()
    table = text.split("part of `corr_cad/mechanics/`")[1].split("\n\n")[0]
    rows = re.findall(r"^\| (\d) \| ([^|]+) \|", table, re.M)
    stated = {
        name.removesuffix(".py").rstrip("/"): int(rank)
        for rank, parts in rows
        for name in re.findall(r"`([\w./]+)`", parts)
    }
    assert stated == {k: v for k, v in MECHANICS_LAYERS.items() if k}


def test_the_mechanics_order_sees_an_import_against_it(monkeypatch):
    """One added edge from the paper's row up to the drive, and one between two rooms of
    one rank (the losses to the row), each break the order inside mechanics."""
    a, b = "corr_cad.mechanics.row.solver", "corr_cad.mechanics.drive.drive"
    monkeypatch.setitem(GRAPH, a, (GRAPH[a][0] | {b}, GRAPH[a][1]))
    with pytest.raises(AssertionError, match="row, rank 1"):
        test_mechanics_imports_one_way()
    monkeypatch.undo()
    a, b = "corr_cad.mechanics.losses.friction", "corr_cad.mechanics.row.solver"
    monkeypatch.setitem(GRAPH, a, (GRAPH[a][0] | {b}, GRAPH[a][1]))
    with pytest.raises(AssertionError, match="losses, rank 1"):
        test_mechanics_imports_one_way()


def _cycle() -> list[str] | None:
    """One import cycle among the package's modules, or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> list[str] | None:
        state[m] = 1
        stack.append(m)
        for d in sorted(GRAPH[m][0]):
            if d.count(".") and d.rsplit(".", 1)[0] == m:
                continue  # a package's __init__ naming its own submodule
            if state.get(d) == 1:
                return stack[stack.index(d) :] + [d]
            if d not in state:
                found = visit(d)
                if found:
                    return found
        stack.pop()
        state[m] = 2
        return None

    for m in sorted(GRAPH):
        if m not in state:
            found = visit(m)
            if found:
                return found
    return None


def test_no_import_cycle():
    cycle = _cycle()
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_the_cycle_finder_finds_a_cycle(monkeypatch):
    """The walk sees a cycle closed by one added edge (design -> profile -> design)."""
    a, b = "corr_cad.geometry.design", "corr_cad.geometry.profile"
    assert a in GRAPH[b][0]
    monkeypatch.setitem(GRAPH, a, (GRAPH[a][0] | {b}, GRAPH[a][1]))
    assert _cycle() == [a, b, a]


def test_only_the_exporters_touch_file_formats():
    bad = [
        f"{m} imports {lib}"
        for m, (_, outer) in GRAPH.items()
        for lib in sorted(outer & set(EXPORT_ONLY))
        if not m.startswith("corr_cad.export")
    ]
    assert not bad, "\n".join(bad)


#: The one exception to the core's libraries: the plane-stress finite elements of the
#: elastic bodies (scikit-fem), in one module (docs/development.md, "Layout and layers").
FE_MODULE = "corr_cad.mechanics.bodies.plane"


def test_the_numerical_core_is_numpy_and_scipy():
    allowed = {"numpy", "scipy", "numba", "shapely", "__future__", "typing"}
    core = ("corr_cad.geometry", "corr_cad.mechanics", "corr_cad.tolerance", "corr_cad.shop")
    bad = []
    for m, (_, outer) in GRAPH.items():
        if m.startswith(core):
            import sys

            third = {o for o in outer if o not in sys.stdlib_module_names}
            ok = allowed | ({"skfem"} if m == FE_MODULE else set())
            bad += [f"{m} imports {o}" for o in sorted(third - ok)]
    assert not bad, "\n".join(bad)
    assert "skfem" in GRAPH[FE_MODULE][1]  # the exception names a module that uses it


@pytest.mark.parametrize("name", sorted(MODULES))
def test_no_module_is_too_long(name):
    lines = len(MODULES[name].read_text().splitlines())
    assert lines <= MAX_LINES, f"{name}: {lines} lines (split it by concept)"


def test_each_subpackage_says_what_it_holds_and_may_import():
    subs = ("geometry", "mechanics", "tolerance", "shop", "export", "run")
    subs += tuple(
        f"{pkg}/{s}"
        for pkg, layers in (("run", RUN_LAYERS), ("mechanics", MECHANICS_LAYERS))
        for s in layers
        if s and (PKG / pkg / s / "__init__.py").is_file()
    )
    for sub in subs:
        doc = ast.get_docstring(ast.parse((PKG / sub / "__init__.py").read_text())) or ""
        assert "May import" in doc and len(doc.splitlines()) >= 3, sub


def test_the_run_order_sees_an_import_against_it(monkeypatch):
    """One added edge from the scene to the stage graph breaks the order inside run."""
    a, b = "corr_cad.run.scene.scene", "corr_cad.run.stages.stages"
    monkeypatch.setitem(GRAPH, a, (GRAPH[a][0] | {b}, GRAPH[a][1]))
    with pytest.raises(AssertionError, match="scene, rank 1"):
        test_run_imports_one_way()
