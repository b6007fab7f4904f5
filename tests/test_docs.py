"""The documentation: it stands alone, covers every entry point, and builds in strict mode."""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from .test_api import EXPECTED

ROOT = Path(__file__).resolve().parents[1]


def test_docs_stand_alone():
    """No file points the reader to a specification outside the repository."""
    outside = re.compile("|".join(re.escape(name) for name in ("MODEL" + ".md", "DESIGN" + ".md", "../" + "shared")))
    files = [ROOT / "README.md", *(ROOT / "docs").rglob("*.md"), *(ROOT / "examples").rglob("*.py")]
    for folder in ("src", "tests", "benchmarks", "scripts"):
        files += [p for p in (ROOT / folder).rglob("*") if p.suffix in (".py", ".md", ".sh", ".toml")]
    hits = [f"{p.relative_to(ROOT)}:{n}" for p in files for n, line in enumerate(p.read_text().splitlines(), 1)
            if outside.search(line)]
    assert not hits, hits


def _table_defaults(text: str) -> dict[str, str]:
    """``| `key` | default | ...`` rows of the Markdown tables headed ``| key | default |``
    (not the bounds table): key -> default as written."""
    tables = re.findall(r"^\| key \| default \|.*\n((?:\|.*\n?)*)", text, flags=re.MULTILINE)
    rows = [row for table in tables
            for row in re.findall(r"^\| `([a-z_]+(?:\.[a-z0-9_]+)?)` \| ([^|]+) \|", table, flags=re.MULTILINE)]
    return {key: default.strip() for key, default in rows}


def _as_written(value) -> str | float | tuple:
    """A default in the form the table writes it (numbers compared as floats)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'`"{value}"`'
    if isinstance(value, tuple):
        return tuple(float(v) for v in value)
    return float(value)


def test_model_page_lists_every_key_with_its_default():
    """docs/model.md section 6 has a row for every configuration key, with the code's default."""
    from polywear.params import Params, StudySpec, flat_items

    documented = _table_defaults((ROOT / "docs" / "model.md").read_text())
    for key, value, _ in flat_items(Params(), StudySpec()):
        if isinstance(value, tuple) and (not value or not isinstance(value[0], (int, float))):
            assert f"[[{key}]]" in (ROOT / "docs" / "model.md").read_text(), key  # array of tables
            continue
        assert key in documented, f"{key} is not documented in docs/model.md section 6"
        written = documented[key]
        expected = _as_written(value)
        if isinstance(expected, float):
            assert float(written) == expected, (key, written, value)
        elif isinstance(expected, tuple):
            assert tuple(float(v) for v in written.strip("[]").split(",")) == expected, (key, written, value)
        else:
            assert written == expected, (key, written, value)


def test_api_reference_lists_every_entry_point():
    """Each ``pw.<name>`` function or class has its own entry in docs/api.md."""
    api = (ROOT / "docs" / "api.md").read_text()
    for name, target in EXPECTED.items():
        module, _, attribute = target.partition(":")
        assert f"::: {module}.{attribute}" in api if attribute else f"::: {module}" in api, name


@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("mkdocs") is None, reason="mkdocs not installed (pip install -e '.[docs]')")
def test_mkdocs_build_strict(tmp_path):
    """Guide, model pages and the API reference (mkdocstrings) build with warnings as errors."""
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(ROOT / "mkdocs.yml"), "-d", str(tmp_path)],
        capture_output=True, text=True, cwd=ROOT, timeout=300,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    api = (tmp_path / "api" / "index.html").read_text()
    assert "stability" in api and "bifurcation" in api


def _blocks(text: str, language: str) -> list[str]:
    return re.findall(rf"^```{language}\n(.*?)^```", text, flags=re.MULTILINE | re.DOTALL)


@pytest.mark.slow
@pytest.mark.parametrize("page", ["docs/guide.md", "README.md"])
def test_python_in_the_guide_and_readme_runs(page, tmp_path):
    """The Python blocks of the page run in order, as one script (with the page's TOML file
    saved as my_car.toml where the page shows one) and write the figure they promise."""
    text = (ROOT / page).read_text()
    for toml in _blocks(text, "toml")[:1]:
        (tmp_path / "my_car.toml").write_text(toml)
    code = "\n".join(_blocks(text, "python"))
    assert "import polywear as pw" in code
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=300,
                          env={**os.environ, "MPLBACKEND": "Agg"})
    assert done.returncode == 0, done.stderr[-3000:]
    assert any(p.suffix == ".png" and p.read_bytes()[:4] == b"\x89PNG" for p in tmp_path.iterdir())
