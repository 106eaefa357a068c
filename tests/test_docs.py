"""The documentation: it builds strictly, its examples run, its links resolve.

* the Sphinx site builds with warnings as errors (as ``docs/development.md``
  says to build it), and the built scenes page lists every key of the schema;
* every ``python`` block of ``docs/*.md`` runs: ``>>>`` examples as doctests,
  other blocks as scripts, in a temporary working folder; every ``toml``
  block parses, and every section and key it sets is one the schema knows;
* every relative link and image of the README, the changelog and the pages
  points to a file that exists (and, for ``#anchor`` links into a page, to a
  heading of that page).
"""

from __future__ import annotations

import doctest
import os
import re
import subprocess
import sys
import tomllib
from html.parser import HTMLParser
from pathlib import Path

import pytest

from corr_cad.run.scene.scene_schema import SCHEMA

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = sorted(DOCS.glob("*.md"))
LINKED = [ROOT / "README.md", ROOT / "CHANGELOG.md", ROOT / "tests" / "README.md", *PAGES]
FENCE = re.compile(r"^```(\w*)[^\n]*\n(.*?)^```", re.M | re.S)


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("html")
    env = {**os.environ, "MPLBACKEND": "Agg"}
    res = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", "docs", out],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env=env,
        timeout=900,
    )
    problems = [ln for ln in res.stderr.splitlines() if "WARNING" in ln or "ERROR" in ln]
    assert res.returncode == 0, "\n".join(problems) or res.stderr[-6000:]
    return out


class _Rows(HTMLParser):
    """(section heading, first cell) of every table row, in document order."""

    def __init__(self) -> None:
        super().__init__()
        self.rows: list[tuple[str, str]] = []
        self._heading = ""
        self._in_h = False
        self._cell: list[str] | None = None
        self._first = False

    def handle_starttag(self, tag, attrs):
        if tag in ("h2", "h3"):
            self._in_h, self._heading = True, ""
        elif tag == "tr":
            self._first = True
        elif tag == "td" and self._first:
            self._cell, self._first = [], False

    def handle_endtag(self, tag):
        if tag in ("h2", "h3"):
            self._in_h = False
        elif tag == "td" and self._cell is not None:
            self.rows.append((self._heading.strip(), "".join(self._cell).strip()))
            self._cell = None

    def handle_data(self, data):
        if self._in_h:
            self._heading += data
        if self._cell is not None:
            self._cell.append(data)


@pytest.mark.slow
def test_site_builds_strictly_and_lists_every_scene_key(site):
    parser = _Rows()
    parser.feed((site / "scenes.html").read_text())
    shown = {(h.strip("¶ ").strip(), key) for h, key in parser.rows}
    missing = [
        f"[{section}] {key}"
        for section, keys in SCHEMA.items()
        for key in keys
        if (f"[{section}]", key) not in shown
    ]
    assert not missing, f"keys missing from the built scenes page: {missing}"
    for page in PAGES:
        assert (site / page.with_suffix(".html").name).is_file(), page.name


def _blocks(language: str) -> list[tuple[str, int, str]]:
    out = []
    for page in PAGES:
        text = page.read_text()
        for m in FENCE.finditer(text):
            if m.group(1) == language:
                out.append((page.name, text[: m.start()].count("\n") + 1, m.group(2)))
    return out


PYTHON = _blocks("python")


def test_the_pages_have_python_examples():
    assert {name for name, _, _ in PYTHON} >= {"api.md", "scenes.md"}


@pytest.mark.parametrize("page", sorted({name for name, _, _ in PYTHON}))
def test_python_examples_run(page, tmp_path, monkeypatch):
    """One namespace per page, blocks in order, as a reader would type them."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    globs: dict = {"__name__": "__docs__"}
    flags = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
    for _, line, code in (b for b in PYTHON if b[0] == page):
        if ">>>" in code:
            test = doctest.DocTestParser().get_doctest(code, globs, page, page, line)
            runner = doctest.DocTestRunner(optionflags=flags)
            runner.run(test, clear_globs=False)
            globs.update(test.globs)  # DocTest works on a copy of the namespace
            assert runner.failures == 0, f"{page}:{line}: a doctest failed (see output above)"
        else:
            exec(compile(code, f"{page}:{line}", "exec"), globs)


@pytest.mark.parametrize(
    "page, line, text", _blocks("toml"), ids=lambda v: str(v) if isinstance(v, int) else None
)
def test_toml_examples_use_only_keys_the_schema_knows(page, line, text):
    data = tomllib.loads(text)
    # [bearings] holds only tables ([bearings.eccentric], [bearings.crank]), each a section.
    bearings = data.pop("bearings", {})
    tables = list(data.items()) + [(f"bearings.{k}", v) for k, v in bearings.items()]
    while tables:
        section, keys = tables.pop()
        assert section in SCHEMA, f"{page}:{line}: unknown section [{section}]"
        nested = {k for k, v in keys.items() if isinstance(v, dict) and f"{section}.{k}" in SCHEMA}
        tables.extend((f"{section}.{k}", keys[k]) for k in nested)  # [modification.design]
        unknown = sorted(set(keys) - set(SCHEMA[section]) - nested)
        assert not unknown, f"{page}:{line}: unknown keys in [{section}]: {unknown}"


LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")


def _slug(heading: str) -> str:
    """GitHub's and MyST's anchor of a heading."""
    text = re.sub(r"[`*_]", "", heading.strip().lower())
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def _anchors(page: Path) -> set[str]:
    text = FENCE.sub("", page.read_text())
    return {_slug(h) for h in re.findall(r"^#{1,6} (.+)$", text, re.M)}


def _links(path: Path) -> list[str]:
    text = FENCE.sub("", path.read_text())
    text = re.sub(r"`[^`\n]*`", "", text)
    return LINK.findall(text)


@pytest.mark.parametrize("doc", LINKED, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(doc):
    bad = []
    for target in _links(doc):
        if re.match(r"[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:
            continue
        file, _, anchor = target.partition("#")
        dest = (doc.parent / file).resolve() if file else doc
        if not dest.exists():
            bad.append(f"{target}: no such file")
        elif anchor and dest.suffix == ".md" and anchor not in _anchors(dest):
            bad.append(f"{target}: no heading with that anchor")
    assert not bad, f"{doc.relative_to(ROOT)}: " + "; ".join(bad)


def test_the_link_checker_sees_links():
    links = _links(ROOT / "README.md")
    assert "docs/images/preview.png" in links and "docs/scenes.md" in links


PATH_REF = re.compile(
    r"`((?:corr_cad|tests|benchmarks|templates|examples)/[\w./*<>-]+)(?:::(\w+))?"
)


@pytest.mark.parametrize("doc", LINKED, ids=lambda p: str(p.relative_to(ROOT)))
def test_named_files_and_tests_exist(doc):
    """Every repository path a page names in code (``corr_cad/run/folder/outputs.py``,
    ``tests/test_solver.py::test_...``) exists, so a moved module shows here."""
    bad = []
    for path, test in PATH_REF.findall(doc.read_text()):
        path = path.rstrip(".")
        if "<" in path or "*" in path:
            continue
        if not any((ROOT / p).exists() for p in (path, path + ".py")):
            bad.append(path)
        elif test and not re.search(rf"def {test}\b", (ROOT / path).read_text()):
            bad.append(f"{path}::{test}")
    assert not bad, f"{doc.relative_to(ROOT)} names what does not exist: {bad}"


DOTTED = re.compile(r"`(corr_cad(?:\.\w+)+)(?:\(\))?`")


@pytest.mark.parametrize(
    "doc", [d for d in LINKED if d.name != "CHANGELOG.md"], ids=lambda p: str(p.relative_to(ROOT))
)
def test_named_modules_and_objects_import(doc):
    """``corr_cad.run.budget.memory.keep_freed_memory`` and the like resolve (the changelog,
    which names the old module paths, aside)."""
    import importlib

    bad = []
    for dotted in sorted(set(DOTTED.findall(doc.read_text()))):
        parts = dotted.split(".")
        for k in range(len(parts), 0, -1):
            try:
                obj = importlib.import_module(".".join(parts[:k]))
            except ImportError:
                continue
            try:
                for attr in parts[k:]:
                    obj = getattr(obj, attr)
            except AttributeError:
                bad.append(dotted)
            break
        else:
            bad.append(dotted)
    assert not bad, f"{doc.relative_to(ROOT)} names what does not import: {bad}"


def test_every_module_is_in_the_api_reference():
    text = (DOCS / "reference.md").read_text()
    documented = set(re.findall(r"^\.\. automodule:: ([\w.]+)$", text, re.M))
    modules = {
        ".".join(p.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")
        for p in (ROOT / "corr_cad").rglob("*.py")
        if p.name != "__main__.py"
    }
    assert sorted(modules - documented) == [], "add an automodule line to docs/reference.md"
    assert sorted(documented - modules) == [], "docs/reference.md documents a module that is gone"


def test_command_examples_parse():
    """Every ``corr-cad ...`` line of a ``bash`` block is a command the CLI accepts."""
    import shlex

    from corr_cad.run.cli import _parser

    commands = []
    for doc in [ROOT / "README.md", *PAGES]:
        for m in FENCE.finditer(doc.read_text()):
            if m.group(1) == "bash":
                for line in m.group(2).splitlines():
                    for part in line.split("#", 1)[0].split("&&"):
                        words = shlex.split(part)
                        if words[:1] == ["corr-cad"]:
                            commands.append((doc.name, words[1:]))
    assert len(commands) >= 8
    for name, args in commands:
        if args == ["bench", "--help"]:
            continue
        try:
            _parser().parse_args(args)
        except SystemExit:
            pytest.fail(f"{name}: corr-cad {' '.join(args)} does not parse")


#: Words of the work's history, not of the tool: issue numbers, who wrote what, what changed.
PROCESS_WORDS = re.compile(
    r"\bissues? \d+|\bhelper\b|\bred-team\b|\bnew keys\b|\bas before\b|\bthis release\b"
    r"|\bissue case\b|\bbefore this (?:work|change)\b",
    re.I,
)


@pytest.mark.parametrize(
    "doc",
    [ROOT / "README.md", *(p for p in PAGES if p.name != "changelog.md")],
    ids=lambda p: p.name,
)
def test_the_manual_speaks_of_the_tool_not_of_its_history(doc):
    """Code spans and file names aside (a test file may carry a number), no page speaks of
    issues, helpers or what was there before: that is the changelog's."""
    text = re.sub(r"`[^`\n]*`", "", FENCE.sub("", doc.read_text()))
    found = sorted({m.group(0) for m in PROCESS_WORDS.finditer(text)})
    assert not found, f"{doc.name}: {found}"


def test_readme_and_getting_started_link_every_page():
    """Every page of the manual is one link away from the README and from Getting started."""
    pages = {p.name for p in PAGES} - {"index.md", "changelog.md", "getting-started.md"}
    readme = (ROOT / "README.md").read_text()
    start = (DOCS / "getting-started.md").read_text()
    assert not sorted(p for p in pages if f"(docs/{p}" not in readme), "README"
    assert not sorted(p for p in pages if f"({p}" not in start), "getting-started.md"


def test_stated_ranges_are_the_loaders():
    """The key reference's range of max_failure_probability is what the loader refuses,
    and every memory-budget note names the loader's default budget."""
    from corr_cad.errors import SceneError
    from corr_cad.run.budget.resources import DEFAULT_MEMORY_GB
    from corr_cad.run.scene.scene import parse_scene
    from corr_cad.run.scene.scene_key import key_range

    assert key_range(SCHEMA["checks"]["max_failure_probability"]) == "[0, 1]"
    for bad in ("-0.01", "1.01"):
        with pytest.raises(SceneError, match=re.escape("allowed range is [0, 1]")):
            parse_scene({"checks": {"max_gear_force": 1e4, "max_failure_probability": float(bad)}})
    notes = [k.note for sec in SCHEMA.values() for k in sec.values() if "memory budget" in k.note]
    assert notes and all(f"default {DEFAULT_MEMORY_GB:g} GB" in n for n in notes), notes


@pytest.mark.slow
def test_wide_tables_wrap_in_the_content_column(site):
    """docs/_static/tables.css lets table cells wrap instead of scrolling out of sight
    (checked by eye in headless Chromium at 1280 px); every page links it."""
    css = (site / "_static" / "tables.css").read_text()
    assert "overflow-x: visible" in css and "overflow-wrap" in css
    for page in ("scenes.html", "gcode.html", "datasheet.html"):
        assert "_static/tables.css" in (site / page).read_text(), page
