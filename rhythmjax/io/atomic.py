"""Atomic outputs (RELIABILITY.md): a temp file beside the target that keeps its suffix, fsync,
then `os.replace`, so an interrupted run leaves the previous output intact; `check_writable`
refuses an unwritable destination before any work."""

from __future__ import annotations

import contextlib
import errno
import os
import secrets
from collections.abc import Iterator
from typing import IO, Any

from .errors import BadInput, PathLike


def _temp_name(path: str) -> str:
    d, base = os.path.split(path)
    stem, suffix = os.path.splitext(base)
    return os.path.join(d, f".{stem}.{secrets.token_hex(4)}.tmp{suffix}")


def _fsync(path: str) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _target(path: PathLike) -> str:
    p = os.fspath(path)
    return os.path.realpath(p) if os.path.islink(p) else p


def _commit(tmp: str, final: str) -> None:
    with contextlib.suppress(OSError):  # keep the permissions of the file being replaced
        os.chmod(tmp, os.stat(final).st_mode & 0o7777)
    os.replace(tmp, final)
    with contextlib.suppress(OSError):  # best effort: not every filesystem allows it
        _fsync(os.path.dirname(final) or ".")


@contextlib.contextmanager
def atomic_write(path: PathLike, mode: str = "wb") -> Iterator[IO[Any]]:
    """Open a temp file beside `path` (``.<stem>.<random>.tmp<suffix>``) for writing; on success
    flush, fsync and rename it over `path`; on any exception (Ctrl-C included) remove it and
    re-raise, leaving the previous `path` untouched. Text modes are UTF-8 with ``newline=""``."""
    if not mode.startswith(("w", "x")) or "+" in mode:
        raise ValueError(f"atomic_write needs a write mode, got {mode!r}")
    final = _target(path)
    f, tmp = _open_temp(final, mode)
    try:
        with f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        _commit(tmp, final)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


@contextlib.contextmanager
def atomic_path(path: PathLike) -> Iterator[str]:
    """Yield a temp PATH beside `path` that keeps its suffix, for writers that take a file name
    (cv2.VideoWriter, pyarrow.parquet.write_table, savefig); rename it over `path` on success,
    remove it on failure. A writer that created no file is an error (OSError ENOENT)."""
    final = _target(path)
    check_writable(final)
    tmp = _temp_name(final)
    try:
        yield tmp
        if not os.path.isfile(tmp):
            raise FileNotFoundError(errno.ENOENT, "the writer created no file", tmp)
        _fsync(tmp)
        _commit(tmp, final)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def make_output_dir(path: PathLike) -> None:
    """Create the output directory `path` (and its parents) if needed; a path that cannot be a
    directory (a file in the way, no permission) is a `BadInput` naming it."""
    try:
        os.makedirs(path, exist_ok=True)
    except OSError as e:
        raise BadInput(os.fspath(path), f"cannot create the output directory: "
                                        f"{e.strerror or e}") from None


def check_writable(path: PathLike) -> None:
    """Fail fast (before any work) if `path` cannot be written: its directory is missing or not
    writable, or `path` is a directory. Probes with a real temp file, so it holds for root too."""
    f, probe = _open_temp(os.fspath(path), "wb")
    f.close()
    os.unlink(probe)


def _open_temp(final: str, mode: str) -> tuple[IO[Any], str]:
    """Create the temp file for `final` exclusively (permissions from the umask, as for a plain
    open); a missing or unwritable directory is a `BadInput` naming `final`."""
    d = os.path.dirname(os.path.abspath(final))
    if os.path.isdir(final):
        raise BadInput(final, "is a directory, not an output file")
    if not os.path.isdir(d):
        raise BadInput(final, f"output directory '{d}' does not exist")
    text = "b" not in mode
    while True:
        tmp = _temp_name(final)
        try:
            return open(tmp, mode.replace("w", "x"), encoding="utf-8" if text else None,
                        newline="" if text else None), tmp
        except FileExistsError:
            continue
        except OSError as e:
            raise BadInput(final, f"cannot write in '{d}': {e.strerror or e}") from None
