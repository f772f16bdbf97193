"""A griffe extension for the API reference (mkdocs.yml): the docstrings' Sphinx roles
(``:class:`AidingSource```, ``:meth:`~tauvcore.x.Y.z```) shown as code, the last part of the
name when it starts with ``~`` (as Sphinx shows it), and reST's double backquotes as Markdown's
single ones."""

from __future__ import annotations

import re
from typing import Any

import griffe

ROLE = re.compile(r":(?:class|attr|meth|mod|func|data|exc|obj|const):`(~?)([^`]+)`")


def _plain(text: str) -> str:
    text = ROLE.sub(lambda m: f"`{m.group(2).rsplit('.', 1)[-1] if m.group(1) else m.group(2)}`", text)
    return re.sub(r"``([^`]+)``", r"`\1`", text)


class SphinxRoles(griffe.Extension):
    def on_object(self, *, obj: griffe.Object, **kwargs: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = _plain(obj.docstring.value)
