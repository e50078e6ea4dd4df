"""The error a user's unusable input raises: `BadInput`, one line naming the file and where."""

from __future__ import annotations

import os


PathLike = str | os.PathLike


class BadInput(ValueError):
    """A user's file is unusable. `str()` is one line naming the file and where: the CSV `line`
    (1-based, header = line 1) or Parquet `row` (1-based), the `column`, the `track_id` or the
    config `key`. The command line prints it and exits 2."""

    def __init__(self, path: PathLike, message: str, *, line: int | None = None,
                 row: int | None = None, column: str | int | None = None,
                 track_id: str | None = None, key: str | None = None):
        self.path, self.message = os.fspath(path), message
        self.line, self.row, self.column, self.track_id, self.key = line, row, column, track_id, key
        super().__init__(self._text())

    def _text(self) -> str:
        head, msg = self.path, self.message
        if self.track_id is not None:
            msg = f"track {self.track_id}: {msg}"
        elif self.line is not None or self.row is not None:
            head += f" line {self.line}" if self.line is not None else f" row {self.row}"
            if isinstance(self.column, int):
                head += f" col {self.column}"
            elif self.column is not None:
                head += f", column '{self.column}'"
        return f"{head}: {msg}".replace("\n", " ")


def read_text(path: PathLike, what: str = "file") -> str:
    """The UTF-8 text of the file at `path` (a leading byte-order mark dropped). Raises
    `BadInput` naming it for a directory ("is a directory, not a `what`"), a missing file, text
    that is not UTF-8, or an OS error."""
    p = os.fspath(path)
    if os.path.isdir(p):
        raise BadInput(p, f"is a directory, not a {what}")
    try:
        with open(p, "rb") as f:
            return f.read().decode("utf-8-sig")
    except FileNotFoundError:
        raise BadInput(p, "no such file") from None
    except UnicodeDecodeError:
        raise BadInput(p, "not UTF-8 text") from None
    except OSError as e:
        raise BadInput(p, f"cannot read: {e.strerror}") from None
