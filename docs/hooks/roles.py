"""MkDocs hook: Sphinx-style roles in docstrings (``:func:`x```) as links in the API pages.

The docstrings name other objects the Sphinx way, ``:mod:`~fusion.io``` or ``:func:`load_run```.
Rendered as Markdown they read ``:mod:<code>~fusion.io</code>``. This hook turns each into a cross
reference that mkdocs-autorefs resolves when the object has a page, and into plain code otherwise
(a leading ``~`` shows only the last name, as in Sphinx).
"""

from __future__ import annotations

import html
import re

ROLE = re.compile(r":(?:py:)?(?:mod|class|func|meth|attr|data|exc|obj|const):<code>(~?)([^<]+)</code>")


def _replace(match: re.Match[str]) -> str:
    short, target = match.group(1), html.unescape(match.group(2)).strip()
    target = target.removesuffix("()")
    shown = target.rsplit(".", 1)[-1] if short else target
    if "." not in target:
        return f"<code>{html.escape(shown)}</code>"
    return (f'<autoref identifier="{html.escape(target)}" optional>'
            f"<code>{html.escape(shown)}</code></autoref>")


def on_page_content(content: str, page, config, files) -> str:  # noqa: ANN001, ARG001
    """Rewrite the roles of a rendered page."""
    return ROLE.sub(_replace, content)
