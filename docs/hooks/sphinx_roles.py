"""mkdocs hook: render the Sphinx roles of the package's docstrings as code.

The docstrings use Sphinx cross-reference roles (``:class:`~cdcr_gym.params.RobotParams```),
which mkdocstrings' Google-style parser leaves as text ("``:class:RobotParams``"). This hook turns
each rendered role into plain code: ``RobotParams`` for ``~path.RobotParams`` (Sphinx's tilde
means "show the last component"), the full dotted path otherwise.
"""

from __future__ import annotations

import re

_ROLE = re.compile(r":(?:class|func|meth|attr|data|mod|exc|obj):<code>(~?)([^<]+)</code>")


def _replace(match: re.Match[str]) -> str:
    tilde, target = match.groups()
    shown = target.rsplit(".", 1)[-1] if tilde else target
    return f"<code>{shown}</code>"


def on_page_content(html: str, **kwargs) -> str:
    """Replace every rendered ``:role:`target``` by ``<code>target</code>``."""
    return _ROLE.sub(_replace, html)
