"""HTML pages from the Jinja2 templates shipped in ``corr_cad/templates/``.

One environment for every page (``report.html``, ``datasheet.html``):
autoescaped, strict about undefined names, whitespace trimmed, so that a
page is deterministic text for deterministic input.
"""

from __future__ import annotations

__all__ = ["render_template"]


def render_template(name: str, context: dict) -> str:
    """The text of template ``name`` (e.g. ``"report.html.j2"``) rendered with ``context``."""
    from jinja2 import Environment, PackageLoader, StrictUndefined, select_autoescape

    env = Environment(
        loader=PackageLoader("corr_cad", "templates"),
        autoescape=select_autoescape(["html", "j2"]),
        undefined=StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
    )
    return env.get_template(name).render(**context)
