"""The report folder (``polywear.io.fresh_directory``): a rerun replaces only what polywear
wrote there (its manifest), keeps the user's own files and folders, never mixes two runs,
clears the partial folders of killed runs, and lets a signal wait for the swap to end."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from polywear import io
from polywear.io import MANIFEST, clear_stale_partial, fresh_directory, read_manifest

from .cli_runner import run_main


def _names(folder):
    return sorted(p.name for p in folder.iterdir())


def _run(out, files: dict[str, str]):
    with fresh_directory(out) as d:
        for name, text in files.items():
            (d / name).write_text(text)


def test_rerun_keeps_the_users_files(tmp_path):
    out = tmp_path / "out"
    _run(out, {"report.html": "run 1", "design.png": "run 1", "summary.json": "run 1"})
    assert read_manifest(out) == {"report.html", "design.png", "summary.json"}
    (out / "notes.txt").write_text("mine")
    (out / "analysis").mkdir()
    (out / "analysis" / "fit.py").write_text("mine too")
    _run(out, {"report.html": "run 2", "summary.json": "run 2"})  # run 2 has no design.png
    assert _names(out) == [MANIFEST, "analysis", "notes.txt", "report.html", "summary.json"]
    assert (out / "notes.txt").read_text() == "mine" and (out / "analysis" / "fit.py").read_text() == "mine too"
    assert (out / "report.html").read_text() == "run 2" and (out / "summary.json").read_text() == "run 2"
    assert read_manifest(out) == {"report.html", "summary.json"}
    assert _names(tmp_path) == ["out"]  # no temporary folder left


def test_failed_rerun_changes_nothing(tmp_path):
    out = tmp_path / "out"
    _run(out, {"report.html": "run 1", "a.png": "run 1"})
    (out / "notes.txt").write_text("mine")
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    with pytest.raises(RuntimeError):
        with fresh_directory(out) as d:
            (d / "report.html").write_text("run 2, failed")
            raise RuntimeError
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert _names(tmp_path) == ["out"]


def test_folder_without_manifest(tmp_path):
    """A report folder of an older polywear (no manifest): files of the names the run
    writes are replaced, everything else is kept."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "report.html").write_text("old version")
    (out / "notes.txt").write_text("mine")
    _run(out, {"report.html": "new", "bifurcation.png": "new"})
    assert _names(out) == [MANIFEST, "bifurcation.png", "notes.txt", "report.html"]
    assert (out / "report.html").read_text() == "new" and (out / "notes.txt").read_text() == "mine"
    assert read_manifest(out) == {"report.html", "bifurcation.png"}


def test_stale_partial_folders_are_cleared(tmp_path):
    out = tmp_path / "out"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    killed = tmp_path / f".out.new-{dead.pid}-abc123"  # a run that was killed (SIGKILL)
    running = tmp_path / f".out.new-{os.getpid()}-def456"  # a run still going (this process)
    legacy_old = tmp_path / ".out.new-k2j4h5"  # an older polywear's, no process id, untouched for 2 h
    legacy_new = tmp_path / ".out.new-q8w7e6"  # the same, touched a minute ago
    other = tmp_path / f".other.new-{dead.pid}-abc123"  # another folder's
    for folder in (killed, running, legacy_old, legacy_new, other):
        folder.mkdir()
        (folder / "stability.png").write_text("partial")
    hours_ago = time.time() - 2 * io.STALE_UNKNOWN_OWNER_S
    for path in (legacy_old / "stability.png", legacy_old):
        os.utime(path, (hours_ago, hours_ago))
    minute_ago = time.time() - 60.0
    os.utime(legacy_new, (minute_ago, minute_ago))
    assert sorted(clear_stale_partial(out)) == sorted([killed, legacy_old])
    _run(out, {"report.html": "run"})
    assert _names(tmp_path) == sorted([running.name, legacy_new.name, other.name, "out"])


def test_a_signal_during_the_swap_waits_for_its_end(tmp_path, monkeypatch):
    """SIGTERM arrives while the new files are moved in: the handler's exit runs only
    once the folder holds the complete new run (never a mix of two)."""
    out = tmp_path / "out"
    _run(out, {"report.html": "run 1", "a.png": "run 1", "b.png": "run 1"})
    seen = []
    previous = signal.signal(signal.SIGTERM, lambda *_: io.when_safe(lambda: seen.append(
        {p.name: p.read_text() for p in out.iterdir() if p.name != MANIFEST})))
    replace = os.replace
    sent = []

    def replace_and_signal(src, dst):
        if not sent:
            sent.append(dst)
            os.kill(os.getpid(), signal.SIGTERM)  # the handler runs at the next bytecode
            time.sleep(0.01)
        replace(src, dst)

    monkeypatch.setattr(io.os, "replace", replace_and_signal)
    try:
        _run(out, {"report.html": "run 2", "a.png": "run 2", "b.png": "run 2"})
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert sent and seen == [{"report.html": "run 2", "a.png": "run 2", "b.png": "run 2"}]
    assert io.when_safe(lambda: seen.append("now")) is None and seen[-1] == "now"  # outside a swap: at once


def test_report_refuses_a_folder_of_other_files_naming_them(tmp_path):
    other = tmp_path / "mine"
    other.mkdir()
    for name in ("thesis.tex", "data.csv"):
        (other / name).write_text("keep me")
    code, out, err = run_main(["report", "--out", str(other)])
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert "data.csv, thesis.tex" in err and "other files" in err
    assert _names(other) == ["data.csv", "thesis.tex"]
