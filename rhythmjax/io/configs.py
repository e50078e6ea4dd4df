"""Config files and JSON at the edge: `read_config_dict` (strict JSON: no NaN or Infinity, no
duplicate key, no integer of more than 30 digits, no deep nesting; each a `BadInput` naming the
file and where), `read_config`, `config_or_bad_input` (a `ConfigError` as a `BadInput` naming
the file and the key), `write_config` (atomic) and `dumps_json` (NaN as null)."""

from __future__ import annotations

import json
import math
import os
import re
from typing import Any

import numpy as np

from ..model.config_setup import config_for
from ..model.params import Config, ConfigError, config_to_dict
from .atomic import atomic_write
from .errors import BadInput, PathLike, read_text


class _Token(Exception):
    pass


def _no_constant(token: str) -> Any:
    raise _Token(token)


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in pairs:
        if k in out:
            raise _Token(f"duplicate key {k!r}")
        out[k] = v
    return out


def _no_huge_int(token: str) -> int:
    if len(token.lstrip("-")) > MAX_INT_DIGITS:
        raise _Token(token)
    return int(token)


MAX_INT_DIGITS = 30  # a longer integer in a config is no usable number
MAX_DEPTH = 64  # JSON nesting a config may have (it needs 3 levels)


def _depth(text: str) -> int:
    """The deepest nesting of objects and lists in JSON `text` (strings skipped)."""
    depth = best = 0
    for m in re.finditer(r'"(?:[^"\\]|\\.)*"|[\[\]{}]', text):
        c = m.group()
        if c in "[{":
            depth += 1
            best = max(best, depth)
        elif c in "]}":
            depth -= 1
    return best


def read_config_dict(path: PathLike) -> dict:
    """The JSON object of a config file as written (keys not filled in). Raises `BadInput`
    naming the file and the line/col (syntax, an integer of more than 30 digits), the token
    (NaN, Infinity), the duplicate key, or nesting deeper than 64 levels."""
    p = os.fspath(path)
    text = read_text(p, "config file")
    if not text.strip():
        raise BadInput(p, "empty file (expected a JSON object)")
    if _depth(text) > MAX_DEPTH:
        raise BadInput(p, f"JSON nested more than {MAX_DEPTH} levels deep (a config has 2)")
    try:
        d = json.loads(text, parse_constant=_no_constant, object_pairs_hook=_no_duplicates,
                       parse_int=_no_huge_int)
    except json.JSONDecodeError as e:
        raise BadInput(p, e.msg, line=e.lineno, column=e.colno) from None
    except RecursionError:
        raise BadInput(p, "JSON nested too deeply") from None
    except _Token as e:
        what = str(e)
        if what.startswith("duplicate"):
            raise BadInput(p, f"{what} (each key may appear once per object)") from None
        if what.lstrip("-").isdigit():
            k = text.find(what)
            line = text.count("\n", 0, k) + 1
            raise BadInput(p, f"an integer of {len(what.lstrip('-'))} digits is no usable number "
                           f"(at most {MAX_INT_DIGITS})", line=line,
                           column=k - text.rfind("\n", 0, k)) from None
        m = re.search(r'(?<![\w"])' + re.escape(what) + r'(?![\w"])', text)
        loc = {}
        if m:
            line = text.count("\n", 0, m.start()) + 1
            loc = {"line": line, "column": m.start() - text.rfind("\n", 0, m.start())}
        raise BadInput(p, f"{what} is not valid JSON (give a number, or omit the key for the "
                       "default)", **loc) from None
    if not isinstance(d, dict):
        raise BadInput(p, "config: expected a JSON object at the top level", key="config")
    return d


def read_config(path: PathLike, *, image_size=None, fps=None) -> Config:
    """Read a config JSON; what it leaves out takes the defaults, or the video's facts
    (`image_size` (w, h) px, `fps`) where given (`model.config_setup.config_for`). Raises
    `BadInput` naming the file and the line/col, the token, the duplicate key or the config key."""
    return config_or_bad_input(read_config_dict(path), os.fspath(path), image_size=image_size,
                               fps=fps)


def config_or_bad_input(d, path, *, image_size=None, fps=None) -> Config:
    """`config_for(d, ...)`, a `ConfigError` raised as `BadInput` naming `path` and the key."""
    try:
        return config_for(d, image_size=image_size, fps=fps)
    except ConfigError as e:
        raise BadInput(path, str(e), key=e.key) from None


def write_config(path: PathLike, cfg: Config) -> None:
    """Write the full config (sections in `config_to_dict` order) as JSON, atomically."""
    text = json.dumps(config_to_dict(cfg), indent=2, allow_nan=False)
    with atomic_write(path, "w") as f:
        f.write(text + "\n")


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def dumps_json(obj: Any, **kwargs: Any) -> str:
    """`json.dumps` for `--json` outputs: NumPy values become Python ones and NaN/inf become
    null, so the output is always valid JSON (`allow_nan=False`)."""
    return json.dumps(_jsonable(obj), allow_nan=False, **kwargs)
