"""Writing files so that a reader never sees half of one.

Every file polywear writes goes through :func:`atomic_path`: the writer fills a
temporary file in the same directory, which is renamed onto the target only when the
writer has finished (``os.replace`` is atomic on one file system). An error or Ctrl-C
on the way removes the temporary file and leaves an existing target untouched.
:func:`fresh_directory` does the same for a folder of results (the report): the run
writes into a new sibling folder, whose files replace those of the previous run at the
end (a manifest in the folder lists them), so a folder never mixes files of two runs,
and the user's own files in it are kept. A signal that arrives while the files are
being swapped in is acted on when the swap is done (:func:`when_safe`).
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

__all__ = ["atomic_path", "write_text", "fresh_directory", "remove_partial", "when_safe", "MANIFEST"]

_PARTIAL: set[Path] = set()
"""Temporary files and folders being written now (removed by :func:`remove_partial`)."""


def remove_partial() -> None:
    """Delete every temporary file or folder still being written (for an immediate exit:
    the command line's Ctrl-C handler calls it before ``os._exit``)."""
    for path in list(_PARTIAL):
        if path.is_dir():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink(missing_ok=True)
        _PARTIAL.discard(path)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path next to ``path`` (same suffix) that replaces ``path`` on success.

    Parameters
    ----------
    path : the file to write; its directory must exist.

    Yields
    ------
    Path
        Where the writer writes (e.g. ``fig.savefig(tmp)``, ``dataset.to_netcdf(tmp)``).
        Renamed onto ``path`` when the block ends normally, deleted otherwise.
    """
    path = Path(path)
    fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=f".part{path.suffix}")
    os.close(fd)
    tmp = Path(name)
    _PARTIAL.add(tmp)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the file the usual permissions
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    finally:
        _PARTIAL.discard(tmp)


def write_text(path: str | Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


MANIFEST = ".polywear-files"
"""The file in a results folder that lists what polywear wrote there (one name a line)."""
_NEW_INFIX = ".new-"
"""A run's partial folder is ``.NAME.new-PID-<random suffix>`` next to the folder NAME."""
STALE_UNKNOWN_OWNER_S = 3600.0
"""A partial folder without a recorded process id (written by an older polywear) is
cleared when nothing in it changed for this long [s]."""

_CRITICAL = 0
"""Depth of the sections that a signal handler must not cut short (the swap of a folder)."""
_DEFERRED: list = []
"""Actions requested by a signal handler during such a section, run when it ends."""


def when_safe(action) -> None:
    """Run ``action()`` now, or, inside the swap of a results folder, right after it (a
    signal handler that exits calls this: an exit in the middle of the swap would leave
    a folder of two runs)."""
    if _CRITICAL:
        _DEFERRED.append(action)
    else:
        action()


@contextmanager
def _uninterruptible() -> Iterator[None]:
    global _CRITICAL
    _CRITICAL += 1
    try:
        yield
    finally:
        _CRITICAL -= 1
        if not _CRITICAL:
            while _DEFERRED:
                _DEFERRED.pop(0)()


def read_manifest(folder: Path) -> set[str] | None:
    """Names polywear wrote in ``folder`` (its manifest), None if it has none."""
    try:
        text = (Path(folder) / MANIFEST).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return None
    return {line for line in text.splitlines() if line and not line.startswith("#") and "/" not in line
            and line not in (".", "..", MANIFEST)}


def _write_manifest(folder: Path, names) -> None:
    write_text(folder / MANIFEST, "# written by polywear; other files in this folder are yours and are kept\n"
               + "".join(f"{n}\n" for n in sorted(names)))


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    elif path.exists() or path.is_symlink():
        path.unlink()


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def _newest_mtime(folder: Path) -> float:
    times = [folder.lstat().st_mtime]
    for entry in folder.iterdir():
        try:
            times.append(entry.lstat().st_mtime)
        except OSError:
            pass
    return max(times)


def clear_stale_partial(path: str | Path) -> list[Path]:
    """Remove the partial folders ``.NAME.new-*`` that interrupted runs left next to
    ``path`` (killed before they could clean up): those whose process (its id is in the
    name) has ended, and those without a recorded id untouched for
    ``STALE_UNKNOWN_OWNER_S``. Folders of runs still going are kept. Returns the removed."""
    path = Path(path)
    removed = []
    prefix = f".{path.name}{_NEW_INFIX}"
    try:
        siblings = [p for p in path.parent.iterdir() if p.name.startswith(prefix) and p.is_dir()
                    and not p.is_symlink() and p not in _PARTIAL]
    except OSError:
        return removed
    now = time.time()
    for folder in siblings:
        pid_text = folder.name[len(prefix):].split("-", 1)[0]
        try:
            if pid_text.isdigit() and "-" in folder.name[len(prefix):]:
                stale = not _pid_alive(int(pid_text))
            else:
                stale = now - _newest_mtime(folder) > STALE_UNKNOWN_OWNER_S
        except OSError:
            continue
        if stale:
            shutil.rmtree(folder, ignore_errors=True)
            removed.append(folder)
    return removed


def _swap_in(new: Path, path: Path) -> None:
    """Move the complete run in ``new`` into ``path``: polywear's files of the previous
    run (its manifest; without one, those of the same names) are replaced or removed,
    every other entry stays."""
    names = {p.name for p in new.iterdir()} - {MANIFEST}
    if not path.exists():
        _write_manifest(new, names)
        os.chmod(new, 0o777 & ~_umask())
        os.replace(new, path)
        return
    previous = read_manifest(path)
    ours = (previous if previous is not None else set()) | {n for n in names if (path / n).exists()}
    # the manifest first claims both runs' files: a crash in the middle leaves no file unowned
    _write_manifest(path, ours | names)
    for name in sorted(ours - names):
        _remove(path / name)
    for name in sorted(names):
        target = path / name
        if target.is_dir() and not target.is_symlink() and not (new / name).is_dir():
            shutil.rmtree(target)
        elif (new / name).is_dir() and (target.exists() or target.is_symlink()):
            _remove(target)
        os.replace(new / name, target)
    _write_manifest(path, names)
    new.rmdir()


@contextmanager
def fresh_directory(path: str | Path) -> Iterator[Path]:
    """A new empty folder next to ``path`` whose files replace polywear's files in the
    folder ``path`` on success.

    The previous run's files (listed in the folder's manifest :data:`MANIFEST`) are
    replaced or removed only after the new run is complete; every other entry of the
    folder (the user's own files and folders) is kept. On an error, Ctrl-C or SIGTERM
    the new folder is deleted and the folder is left as it was. Partial folders of
    earlier interrupted runs are cleared first (:func:`clear_stale_partial`).
    """
    path = Path(path)
    clear_stale_partial(path)
    new = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}{_NEW_INFIX}{os.getpid()}-"))
    _PARTIAL.add(new)
    try:
        yield new
        with _uninterruptible():
            _PARTIAL.discard(new)  # from here on the handler waits for the swap
            _swap_in(new, path)
    except BaseException:
        shutil.rmtree(new, ignore_errors=True)
        raise
    finally:
        _PARTIAL.discard(new)
