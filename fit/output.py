"""What `rhythmjax-fit` writes: a config, atomically, with the exit code and message its verbs
share (0 written, 2 bad input naming the file, 1 the output cannot be written)."""

from __future__ import annotations

import json
import sys
from collections.abc import Callable


def write_json(path: str, d: dict) -> None:
    """`d` as indented JSON (no NaN), written atomically (`rhythmjax.io.atomic_write`)."""
    from rhythmjax.io import atomic_write

    with atomic_write(path, "w") as f:
        f.write(json.dumps(d, indent=2, allow_nan=False) + "\n")


def write_output(path: str, write: Callable[[], None], *, quiet: bool = False) -> int:
    """Run `write` (which writes `path`) and return the exit code: 2 on `BadInput` (its one
    line), 1 when the file cannot be written, else 0 with "wrote PATH" unless `quiet`."""
    from rhythmjax.io import BadInput

    try:
        write()
    except BadInput as e:
        print(f"rhythmjax-fit: {e}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"rhythmjax-fit: {path}: cannot write: {e.strerror}", file=sys.stderr)
        return 1
    if not quiet:
        print(f"wrote {path}")
    return 0
