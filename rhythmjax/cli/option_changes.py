"""`--set GROUP.FIELD=VALUE`: any field of a verb's options record from the command line.

The tracker (`track.options.TrackerOptions`, verbs `run` and `track`) and the counting tracker
(`count.options.CountOptions`, verb `count`) carry rules that are built and measured but off by
default (docs/rules.md names each one, where it was chosen and what it did elsewhere). `--set`
reaches every one of them without a new flag per rule: the value is read as the type of the
field's default (true/false, a whole number, a number, a word; none or null where the field may
be None, e.g. `body.column_rows=none`), so a misspelt value is an error naming the field, not a
truthy string.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Sequence
from typing import Any

from ..model.params import ConfigError
from ..track.options import with_changes


__all__ = ["SET_METAVAR", "add_set", "apply_option_changes", "parse_option_changes",
           "recorded"]

SET_METAVAR = "GROUP.FIELD=VALUE"


def add_set(p, record: str) -> None:
    """--set (repeatable) for a verb whose options record is named `record`."""
    p.add_argument("--set", action="append", default=[], dest="option_changes",
                   metavar=SET_METAVAR, help=f"change one field of the {record} options "
                   "(repeatable; applied after the other flags), e.g. appearance.enabled=true; "
                   "a value is read as its field's type: true/false, a whole number, a "
                   "number (inf allowed), a word; none where the field may be None. The "
                   "rules built but off by default, with their measured effect on each "
                   "source, are in docs/rules.md")


def _field(options, dotted: str):
    """(the record holding the field, its name) for `dotted` ('group.field' or 'field')."""
    group, dot, name = dotted.partition(".")
    if not dot:
        group, name = "", group
    record = options
    if group:
        groups = {f.name for f in dataclasses.fields(options)
                  if dataclasses.is_dataclass(getattr(options, f.name))}
        if group not in groups:
            raise ConfigError("--set", f"{type(options).__name__} has no group {group!r} "
                              f"(groups: {', '.join(sorted(groups))})")
        record = getattr(options, group)
    names = {f.name for f in dataclasses.fields(record)
             if not dataclasses.is_dataclass(getattr(record, f.name))}
    if name not in names:
        raise ConfigError("--set", f"{type(record).__name__} has no field {name!r} "
                          f"(fields: {', '.join(sorted(names))})")
    return record, name


def _optional(record, name: str) -> bool:
    """Whether the field `name` of `record` may be None (its annotation names None)."""
    field = next(f for f in dataclasses.fields(record) if f.name == name)
    return "None" in str(field.type)


def _typed(dotted: str, text: str, current: Any) -> Any:
    """`text` read as the type of `current` (the field's present value)."""
    bad = lambda what: ConfigError(  # noqa: E731
        "--set", f"{dotted}={text}: expected {what} (now {current!r})")
    if isinstance(current, bool):
        if text.lower() not in ("true", "false"):
            raise bad("true or false")
        return text.lower() == "true"
    if isinstance(current, int):
        try:
            return int(text)
        except ValueError:
            raise bad("a whole number") from None
    if isinstance(current, float):
        try:
            value = float(text)
        except ValueError:
            raise bad("a number") from None
        if math.isnan(value):
            raise bad("a number, not nan")
        return value
    if isinstance(current, str):
        return text
    try:
        value = json.loads(text)
    except json.JSONDecodeError:
        raise bad("a JSON value") from None
    return tuple(value) if isinstance(current, tuple) and isinstance(value, list) else value


def parse_option_changes(items: Sequence[str], options) -> dict[str, Any]:
    """{'group.field': value} of the `--set` items, each checked against `options` (a grouped
    options record) and read as its field's type; `ConfigError` ('--set: ...') naming the item
    otherwise. A field set twice keeps the last value."""
    out: dict[str, Any] = {}
    for item in items:
        dotted, eq, text = item.partition("=")
        dotted, text = dotted.strip(), text.strip()
        if not eq or not dotted or not text:
            raise ConfigError("--set", f"{item!r}: expected {SET_METAVAR}, e.g. "
                              "appearance.enabled=true")
        record, name = _field(options, dotted)
        if text.lower() in ("none", "null") and _optional(record, name):
            out[dotted] = None  # e.g. body.column_rows=none: rule 54's column off
        else:
            out[dotted] = _typed(dotted, text, getattr(record, name))
    return out


def apply_option_changes(options, items: Sequence[str]):
    """(`options` with the `--set` items applied, the changes as {'group.field': value}); a
    value the record refuses (its own checks, e.g. stitch.max_dv_mps > 0) is a `ConfigError`
    naming it."""
    changes = parse_option_changes(items, options)
    try:
        return with_changes(options, changes), changes
    except (KeyError, ValueError, TypeError) as e:
        raise ConfigError("--set", str(e.args[0] if e.args else e)) from None


def recorded(changes: dict[str, Any]) -> dict[str, Any]:
    """The changes as the summary records them (`option_changes`): JSON has no infinity, so an
    infinite number is written as the text 'inf' / '-inf' rather than null."""
    return {k: (str(v) if isinstance(v, float) and math.isinf(v) else v)
            for k, v in changes.items()}
