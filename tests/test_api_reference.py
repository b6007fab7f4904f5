"""docs/api.md and ``pw.__all__`` agree: every public entry point has its entry (an
identifier that is that object), every entry and every ``pw.<name>`` the page mentions
exists. Fast, without building the docs (``test_docs.py`` builds them with mkdocs --strict)."""

from __future__ import annotations

import re
import types
from importlib import import_module
from pathlib import Path

import polywear as pw

API = (Path(__file__).resolve().parents[1] / "docs" / "api.md").read_text(encoding="utf-8")
PUBLIC = sorted(set(pw.__all__) - {"__version__"})


def _directives(page: str) -> list[str]:
    return re.findall(r"^::: ([\w.]+)", page, flags=re.MULTILINE)


def _resolve(dotted: str) -> object:
    """The object a mkdocstrings identifier names (the longest importable module, then
    attributes); AttributeError or ModuleNotFoundError where there is none."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = import_module(".".join(parts[:cut]))
        except ModuleNotFoundError:
            continue
        for name in parts[cut:]:
            obj = getattr(obj, name)
        return obj
    raise ModuleNotFoundError(dotted)


def _identifier(obj: object) -> str:
    """Where an object is defined, as mkdocstrings names it."""
    return obj.__name__ if isinstance(obj, types.ModuleType) else f"{obj.__module__}.{obj.__qualname__}"


def _missing(page: str) -> list[str]:
    """Public names without an entry on the page."""
    found = []
    for d in _directives(page):
        try:
            found.append(_resolve(d))
        except (AttributeError, ModuleNotFoundError):
            continue
    return [name for name in PUBLIC if not any(obj is getattr(pw, name) for obj in found)]


def _broken(page: str) -> list[str]:
    """Entries of the page that name nothing."""
    out = []
    for d in _directives(page):
        try:
            _resolve(d)
        except (AttributeError, ModuleNotFoundError):
            out.append(d)
    return out


def _stale(page: str) -> list[str]:
    """``pw.<name>`` on the page that polywear does not export."""
    return sorted(set(re.findall(r"\bpw\.([A-Za-z_]\w*)", page)) - set(pw.__all__))


def test_every_public_name_has_its_entry():
    assert not _missing(API), [f"pw.{n}: e.g. '::: {_identifier(getattr(pw, n))}'" for n in _missing(API)]


def test_every_entry_names_an_object():
    assert len(_directives(API)) > len(PUBLIC) and not _broken(API)


def test_every_pw_name_on_the_page_is_public():
    assert re.search(r"\bpw\.stability\b", API) and not _stale(API)


def test_the_checks_catch_a_missing_a_broken_and_a_stale_name():
    planted = (API.replace("::: polywear.params.Params\n", "")
               + "\n::: polywear.dynamics.stability.stability_analysis\n\nCall `pw.stability_analysis(params)`.\n")
    assert _missing(planted) == ["Params"]
    assert _broken(planted) == ["polywear.dynamics.stability.stability_analysis"]
    assert _stale(planted) == ["stability_analysis"]
