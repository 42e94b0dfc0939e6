"""Help texts are plain text: module docstrings (reStructuredText) shown by ``--help`` lose their markup here."""
from __future__ import annotations

import re

__all__ = ["plain_text"]

_ROLE = re.compile(r":[a-z]+:`~?([^`]+)`")


def plain_text(doc: str) -> str:
    """``doc`` without reStructuredText markup: ``:func:`~a.b``` -> ``a.b``, double backquotes and ``::``
    before a literal block removed, so that ``--help`` prints what a terminal user reads."""
    text = _ROLE.sub(r"\1", doc)
    text = text.replace("``", "")
    text = re.sub(r"(\S)::\n", r"\1:\n", text)
    return re.sub(r"\s::\n", "\n", text)
