"""Writing files so that a reader never sees half of one.

Every file polywear writes goes through :func:`atomic_path`: the writer fills a
temporary file in the same directory, which is renamed onto the target only when the
writer has finished (``os.replace`` is atomic on one file system). An error or Ctrl-C
on the way removes the temporary file and leaves an existing target untouched.
:func:`fresh_directory` does the same for a folder of results (the report): the run
writes into a new sibling folder, which replaces the old one at the end, so a folder
never mixes files of two runs.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

__all__ = ["atomic_path", "write_text", "fresh_directory", "remove_partial"]

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


@contextmanager
def fresh_directory(path: str | Path) -> Iterator[Path]:
    """A new empty folder next to ``path`` that replaces the folder ``path`` on success.

    The old folder (if any) is removed only after the new one is complete; on an error
    or Ctrl-C the new folder is deleted and the old one is left as it was.
    """
    path = Path(path)
    new = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.new-"))
    _PARTIAL.add(new)
    old: Path | None = None
    try:
        yield new
        os.chmod(new, 0o777 & ~_umask())
        if path.exists():
            old = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.old-"))
            os.replace(path, old / path.name)
        os.replace(new, path)
    except BaseException:
        if old is not None and not path.exists():  # interrupted between the two renames
            os.replace(old / path.name, path)
        shutil.rmtree(new, ignore_errors=True)
        raise
    finally:
        _PARTIAL.discard(new)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
