"""Griffe extension for the API reference: Sphinx roles in docstrings become links.

The docstrings cite other objects as ``:func:`name```, ``:class:`~pkg.Name``` and so on
(the roles of Sphinx). mkdocstrings renders Markdown, where those roles would show up
literally; this extension rewrites each one, before rendering, as a cross-reference
``[`name`][full.path]`` when the name resolves to an object of the package (relative to
the docstring's scope, or as a full dotted path) that the API reference (api.md) shows,
and as plain code otherwise. Used by mkdocs.yml (``extensions``); not part of the
installed package.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import griffe

_ROLE = re.compile(r":(?:func|class|meth|mod|data|attr|obj|exc):`(~?)([^`]+)`")
_DIRECTIVE = re.compile(r"^::: (\S+)\n((?:    .*\n)*)", re.MULTILINE)


def _rendered() -> tuple[set[str], set[str]]:
    """Objects api.md renders: (shown alone, shown with their public members)."""
    alone, with_members = set(), set()
    for path, options in _DIRECTIVE.findall((Path(__file__).parent / "api.md").read_text()):
        (alone if "members: false" in options else with_members).add(path)
    return alone, with_members


def _shown(path: str, alone: set[str], with_members: set[str]) -> bool:
    """True if the API reference has an entry (an anchor) for ``path``."""
    if any(part.startswith("_") for part in path.split(".")):
        return False
    if path in alone or path in with_members:
        return True
    return any(path.startswith(f"{parent}.") for parent in with_members)


def _target(obj: griffe.Object, name: str, split: bool = True) -> str | None:
    """Full path of ``name`` as seen from ``obj``'s docstring, or None (``split``: also try
    ``Class.member`` with the class resolved in scope; once, so that a member griffe cannot
    find, e.g. an inherited method, ends the search instead of recursing)."""
    name = name.lstrip(".")
    try:
        return obj.resolve(name) if obj.parent is None else obj.parent.resolve(name)
    except griffe.NameResolutionError:
        pass
    try:
        return obj.modules_collection.get_member(name).path
    except (KeyError, ValueError, AttributeError):
        pass
    if split and "." in name:  # a member of a class in scope, e.g. Class.method
        head, _, tail = name.partition(".")
        base = _target(obj, head, split=False)
        if base is not None:
            return _target(obj, f"{base}.{tail}", split=False)
    return None


def _rewrite(obj: griffe.Object, alone: set[str], with_members: set[str]) -> None:
    def link(match: re.Match[str]) -> str:
        short, name = match.group(1), match.group(2)
        shown = name.rsplit(".", 1)[-1] if short else name.lstrip(".")
        path = _target(obj, name)
        return f"[`{shown}`][{path}]" if path and _shown(path, alone, with_members) else f"`{shown}`"

    if obj.docstring is not None:
        obj.docstring.value = _ROLE.sub(link, obj.docstring.value)


class SphinxRoles(griffe.Extension):
    """Rewrite Sphinx roles in every docstring of a loaded package."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        alone, with_members = _rendered()
        stack: list[griffe.Object] = [pkg]
        seen: set[str] = set()
        while stack:
            obj = stack.pop()
            if obj.path in seen:
                continue
            seen.add(obj.path)
            _rewrite(obj, alone, with_members)
            stack += [member for member in obj.members.values() if not member.is_alias]
