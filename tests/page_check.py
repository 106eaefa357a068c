"""Checks of ``datasheet.html`` against ``datasheet.json``: every number of the file is a
figure cell of the page, and every number the page prints in a sentence is one of the
file's (or of the design's) as the page rounds it.

Used by the page tests of the paper's row (``test_datasheet.py``), the whole drive
(``test_datasheet_page.py``) and the Monte Carlo's as-built figures.
"""

from __future__ import annotations

import math
import re
from html.parser import HTMLParser

from corr_cad.export.datasheet_html import json_numbers

#: A number standing alone in a sentence: not part of a name (T_1, K2, L10, A4, ISO/TR),
#: thousands separated or not, never in e-notation.
NUMBER = re.compile(
    r"(?<![\w.^/-])-?\d{1,3}(?:,\d{3})+(?:\.\d+)?(?![\w])"
    r"|(?<![\w.^/-])-?\d+(?:\.\d+)?(?![\w.]\d|[\w])"
)


class Page(HTMLParser):
    """The page's figure cells ``(data-key, data-value, shown text)`` and its other text."""

    def __init__(self, text: str):
        super().__init__()
        self.cells, self.imgs, self.text = [], [], []
        self._open, self._skip = None, 0
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag in ("style", "title"):
            self._skip += 1
        if tag == "td" and "data-key" in a:
            self._open = [a["data-key"], a["data-value"], ""]
        if tag == "img":
            self.imgs.append(a["src"])

    def handle_endtag(self, tag):
        if tag in ("style", "title"):
            self._skip -= 1
        if tag == "td" and self._open is not None:
            self.cells.append(tuple(self._open))
            self._open = None

    def handle_data(self, data):
        if self._open is not None:
            self._open[2] += data
        elif not self._skip:
            self.text.append(data)


def lookup(sheet: dict, key: str):
    v = sheet
    for part in key.split("."):
        v = v[int(part)] if isinstance(v, list) else v[part]
    return v


def shown_matches(shown: str, v: float) -> bool:
    """``shown`` is ``v`` rounded to the digits it prints (catalogue form: no e-notation)."""
    got = float(shown.replace(",", ""))
    if abs(v) < 1e-9:
        return got == 0.0
    decimals = len(shown.split(".")[1]) if "." in shown else 0
    return abs(got - v) <= 0.5 * 10.0**-decimals * (1 + 1e-9) + 1e-12


def check_cells(page: Page, sheet: dict) -> set[str]:
    """Every figure cell holds the JSON's exact value and shows it rounded to at most four
    significant digits; returns the keys of the cells."""
    for key, exact, shown in page.cells:
        v = lookup(sheet, key)
        assert float(exact) == v, key  # the very number of datasheet.json
        assert re.fullmatch(r"-?[0-9,]+(\.[0-9]+)?", shown), (key, shown)  # no e-notation
        assert shown_matches(shown, v), (key, shown, v)
        if abs(v) >= 1e-9:
            digits = max(0, 3 - math.floor(math.log10(abs(v))))
            assert abs(float(shown.replace(",", "")) - v) <= 0.5 * 10.0**-digits * (1 + 1e-9)
    return {k for k, _, _ in page.cells}


def check_every_number_is_a_cell(page: Page, sheet: dict) -> None:
    """Every number of ``datasheet.json`` (friction, life, whole drive, as built...) is a
    figure cell of the page under its key path."""
    keys = {k for k, _, _ in page.cells}
    missing = [k for k, _ in json_numbers(sheet) if k not in keys]
    assert not missing, missing


def sentence_numbers(page: Page, skip: tuple[str, ...] = ()) -> list[str]:
    """The numbers printed in the page's text outside the figure cells (captions,
    conventions, notes, the model); ``skip``: phrases left out (a formula's constants)."""
    text = " ".join(page.text).replace("+-", "+- ")  # +-85.8 N*m: the number is 85.8
    for phrase in skip:
        text = text.replace(phrase, " ")
    return NUMBER.findall(text)


def check_sentence_numbers(page: Page, sheet: dict, design_values=(), skip=()) -> int:
    """Every number in a sentence of the page is one of ``datasheet.json``'s (a figure, or a
    number in one of its texts), a percentage of one (``b = 3 %``), or a design value;
    returns how many numbers were checked."""
    allowed = [v for _, v in json_numbers(sheet)]
    allowed += [100.0 * v for v in list(allowed)]

    def texts(x):
        if isinstance(x, dict):
            for v in x.values():
                yield from texts(v)
        elif isinstance(x, list):
            for v in x:
                yield from texts(v)
        elif isinstance(x, str):
            yield x

    for t in texts(sheet):
        allowed += [float(m.replace(",", "")) for m in NUMBER.findall(t)]
    allowed += [float(v) for v in design_values]
    found = sentence_numbers(page, skip)
    bad = [n for n in found if not any(shown_matches(n, v) for v in allowed)]
    assert not bad, bad
    return len(found)
