"""Atomic outputs (RELIABILITY.md): a temp file beside the target that keeps its suffix, fsync,
then `os.replace`, so an interrupted run leaves the previous output intact; `check_writable`
refuses an unwritable destination before any work."""

from __future__ import annotations

import contextlib
import errno
import os
import secrets
import signal
import sys
import threading
from collections.abc import Iterable, Iterator
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


def make_output_dir(path: PathLike) -> bool:
    """Create the output directory `path` (and its parents) if needed; True if it was created
    now. A path that cannot be a directory (a file in the way, no permission) is a `BadInput`
    naming it."""
    existed = os.path.isdir(path)
    try:
        os.makedirs(path, exist_ok=True)
        return not existed
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
    if os.path.exists(final) and not os.path.isfile(final):
        raise BadInput(final, "is not a regular file (a device, FIFO or socket); give a file "
                              "to write")
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


# -- outputs that are one set, interrupts --------------------------------------------------------
class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread by the handler `raise_on_sigterm` installs, so the
    cleanup of the atomic writers runs as for Ctrl-C; a command line exits 143 for it."""


# The interrupts raised by the handlers of `raise_on_sigterm` and not yet seen by an `OutputSet`.
# Python runs a signal handler in whatever the main thread executes at that moment; when that is a
# finaliser or a garbage-collector callback (JAX registers one), the exception is printed as
# "Exception ignored" and lost, and the run would go on to commit its outputs. `OutputSet`
# re-raises it before the renames instead.
_pending: list[KeyboardInterrupt] = []


def _quiet_unraisable(unraisable) -> None:
    """`sys.unraisablehook` that leaves out the interrupts of `raise_on_sigterm` Python dropped
    (they are pending and re-raised by `OutputSet`: printing them broke the one-line message
    a command gives when interrupted); anything else goes to the previous hook."""
    if any(unraisable.exc_value is e for e in _pending):
        return
    _quiet_unraisable.default(unraisable)


_quiet_unraisable.default = sys.unraisablehook


def raise_on_sigterm() -> None:
    """Make SIGTERM raise `Terminated`, and Ctrl-C (where Python's default handler is in place)
    `KeyboardInterrupt`, each remembered until an `OutputSet` sees it, so that one raised where
    Python drops exceptions still stops the outputs' commit (the application's choice; call it
    from the main thread, at the start of a command: it forgets older interrupts)."""
    def handler(signum, frame):  # noqa: ARG001 - the signal module's signature
        exc = Terminated("terminated (SIGTERM)") if signum == signal.SIGTERM \
            else KeyboardInterrupt()
        _pending.append(exc)
        raise exc

    if threading.current_thread() is threading.main_thread():
        _pending.clear()
        if sys.unraisablehook is not _quiet_unraisable:
            _quiet_unraisable.default = sys.unraisablehook
            sys.unraisablehook = _quiet_unraisable
        signal.signal(signal.SIGTERM, handler)
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            signal.signal(signal.SIGINT, handler)


@contextlib.contextmanager
def signals_deferred() -> Iterator[None]:
    """SIGINT and SIGTERM held back (delivered after the block) while a set is renamed in, or a
    part and the manifest naming it are written (`io.parts`)."""
    held = {signal.SIGINT, signal.SIGTERM}
    main = threading.current_thread() is threading.main_thread()
    if main and hasattr(signal, "pthread_sigmask"):
        old = signal.pthread_sigmask(signal.SIG_BLOCK, held)
        try:
            yield
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)
    else:
        yield


def check_output(path: PathLike, inputs: Iterable[PathLike | None] = ()) -> None:
    """Before any work: `path` can be written (see `check_writable`: its directory exists and is
    writable, it is not a directory, device, FIFO or socket) and is none of `inputs` (the same
    file by `os.path.samefile`, or the same resolved path). A `BadInput` naming `path`."""
    p = os.fspath(path)
    for src in inputs:
        if src is None:
            continue
        s = os.fspath(src)
        same = os.path.realpath(p) == os.path.realpath(s)
        with contextlib.suppress(OSError):
            same = same or os.path.samefile(p, s)
        if same:
            raise BadInput(p, f"is the input '{s}'; give another output, the input would be "
                              "overwritten")
    check_writable(p)


class OutputSet:
    """Files written as one set: each is written to a temp file beside it
    (``.<stem>.<random>.tmp<suffix>``; `path(name)` gives it to the writer), and only when the
    block succeeds are all renamed over the old ones, with SIGINT and SIGTERM held back for the
    renames, and the `drop` files (members of an older set this run does not write) removed. An
    exception (Ctrl-C, SIGTERM through `raise_on_sigterm`) removes the temp files and the
    directory `made` when it was created for this run and is empty, leaving the previous set
    whole. Every path is checked with `check_output` against `inputs` when the set is made."""

    def __init__(self, paths: Iterable[PathLike], *, inputs: Iterable[PathLike | None] = (),
                 drop: Iterable[PathLike] = (), made: PathLike | None = None):
        inputs, paths = list(inputs), [os.fspath(p) for p in paths]
        self.finals = {p: _target(p) for p in paths}
        self.drop = [os.fspath(p) for p in drop if os.fspath(p) not in self.finals]
        self.made = None if made is None else os.fspath(made)
        try:
            real = [os.path.realpath(p) for p in paths]
            twice = [p for p, r in zip(paths, real, strict=True) if real.count(r) > 1]
            if twice:
                raise BadInput(twice[0], "is given as two of the outputs")
            for p in list(self.finals) + self.drop:
                check_output(p, inputs)
        except BaseException:
            self._remove_made()
            raise
        self.temps = {p: _temp_name(f) for p, f in self.finals.items()}

    def path(self, name: PathLike) -> str:
        """The temp path to write for the output `name` (one of the set's paths)."""
        return self.temps[os.fspath(name)]

    def __enter__(self) -> OutputSet:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is not None:
            if issubclass(exc_type, KeyboardInterrupt):
                _pending.clear()  # delivered
            self.abort()
            return
        try:
            if _pending:  # an interrupt raised where Python dropped it (see `_pending`)
                lost = _pending.pop()
                _pending.clear()
                raise lost
            for tmp in self.temps.values():
                if not os.path.isfile(tmp):
                    raise FileNotFoundError(errno.ENOENT, "the writer created no file", tmp)
                _fsync(tmp)
            with signals_deferred():
                for name, tmp in self.temps.items():
                    _commit(tmp, self.finals[name])
                for p in self.drop:
                    with contextlib.suppress(FileNotFoundError):
                        os.unlink(p)
        except BaseException:
            self.abort()
            raise

    def abort(self) -> None:
        """Remove the temp files (and the directory made for this run, if empty)."""
        for tmp in self.temps.values():
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        self._remove_made()

    def _remove_made(self) -> None:
        if self.made is not None:
            with contextlib.suppress(OSError):
                os.rmdir(self.made)
