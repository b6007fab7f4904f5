"""The report is a web page: render report.html in headless Chromium and check what a reader sees.

For both models and for the safe car (no SEV at all), ``polywear report`` runs once per
test session (module-scoped fixture); the page must load with every image decoded, every
local link pointing at a file that exists, and no console error, uncaught exception or
failed load. Chromium comes from Debian's ``chromium`` package (scripts/ensure-chromium.sh,
run by ./test.sh); without it the tests are skipped with the reason.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from .browser import find_chromium, inspect_page
from .cli_runner import run_main

CHROMIUM = find_chromium()
needs_chromium = pytest.mark.skipif(
    CHROMIUM is None, reason="no Chromium on PATH (./test.sh installs Debian's chromium when run as root)"
)

CASES = {
    "tread1dof": ["-s", "model=tread1dof"],
    "axle4dof": ["-s", "model=axle4dof"],
    "safe car": ["-s", "operating.toe_deg=0.05"],
}


@pytest.fixture(scope="module", params=list(CASES), ids=list(CASES))
def report(request, tmp_path_factory) -> tuple[str, Path]:
    """(case, report folder) of one ``polywear report`` run."""
    out = tmp_path_factory.mktemp("report") / "out"
    code, stdout, err = run_main(["report", "-q", "--out", str(out), *CASES[request.param]])
    assert code == 0, err
    assert f"report: {out / 'report.html'}" in stdout
    return request.param, out


@needs_chromium
@pytest.mark.slow
def test_report_renders_without_errors(report):
    case, out = report
    html = out / "report.html"
    page = inspect_page(html, CHROMIUM)
    tags = re.findall(r"<img\b", html.read_text())
    assert len(page["images"]) == len(tags) > 0, case
    broken = [src for src, complete, width in page["images"] if not (complete and width > 0)]
    assert not broken, f"{case}: images that do not load: {broken}"
    assert page["errors"] == [], f"{case}: {page['errors']}"
    links = re.findall(r'href="([^":#]+)"', html.read_text())  # local files only (no scheme, no anchor)
    assert [link for link in links if not (out / link).is_file()] == [], case


@needs_chromium
def test_page_inspection_sees_broken_images_and_script_errors(tmp_path):
    """The check above can fail: a page with a missing image and a script error."""
    import base64

    png = base64.b64decode(  # 1x1 PNG
        "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mNk+M9QDwADhgGAWjR9awAAAABJRU5ErkJggg=="
    )
    (tmp_path / "ok.png").write_bytes(png)
    page = tmp_path / "page.html"
    page.write_text('<html><body><img src="ok.png"><img src="missing.png">'
                    "<script>console.error('boom'); undefined_function();</script></body></html>")
    result = inspect_page(page, CHROMIUM)
    assert result["images"] == [("ok.png", True, 1), ("missing.png", True, 0)]
    errors = " | ".join(result["errors"])
    assert "console: boom" in errors and "exception: Uncaught" in errors, errors
    assert "missing.png" in errors and "ERR_FILE_NOT_FOUND" in errors, errors
