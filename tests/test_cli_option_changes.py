"""`--set GROUP.FIELD=VALUE` (`rhythmjax.cli.option_changes`): every field of the verbs' options
records from the command line, read as its field's type, refused with the item named; and the
verbs `count` and `track` applying it (after their other flags) and saying so in the summary."""

from __future__ import annotations

import csv
import json
import math

import pytest

from rhythmjax.cli.main import main
from rhythmjax.cli.option_changes import apply_option_changes, parse_option_changes, recorded
from rhythmjax.count import CountOptions
from rhythmjax.model.params import ConfigError
from rhythmjax.track.options import TrackerOptions, with_changes

from .test_count import videos  # noqa: F401 - the tiny generated videos (a module fixture)


def test_values_are_read_as_their_fields_type():
    got = parse_option_changes(
        ["appearance.enabled=true", "appearance.veto_distance=0.359", "stitch.max_gap_s=3",
         "appearance.bins=4", "verdicts.speed_fit=theil-sen", "dynamics=2d",
         "stitch.max_dv_mps=inf", "appearance.enabled=False"], CountOptions())
    assert got == {"appearance.enabled": False, "appearance.veto_distance": 0.359,
                   "stitch.max_gap_s": 3.0, "appearance.bins": 4,
                   "verdicts.speed_fit": "theil-sen", "dynamics": "2d",
                   "stitch.max_dv_mps": math.inf}  # the last of a field set twice wins
    assert type(got["appearance.bins"]) is int and type(got["stitch.max_gap_s"]) is float
    assert type(got["appearance.enabled"]) is bool
    assert recorded(got)["stitch.max_dv_mps"] == "inf" and recorded({"a.b": -math.inf}) == {
        "a.b": "-inf"}
    assert recorded(got)["appearance.veto_distance"] == 0.359  # finite values as they are


def test_applied_as_with_changes_applies_them():
    items = ["appearance.enabled=true", "appearance.veto_distance=0.359", "max_pedestrians=5"]
    opt, changes = apply_option_changes(CountOptions(), items)
    assert opt == with_changes(CountOptions(), changes)
    assert opt.appearance.enabled is True and opt.appearance.veto_distance == 0.359
    assert opt.max_pedestrians == 5 and opt.stitch == CountOptions().stitch
    same, none = apply_option_changes(TrackerOptions(), [])
    assert same == TrackerOptions() and none == {}
    opt, _ = apply_option_changes(TrackerOptions(), ["body.window_candidates=true"])
    assert opt.body.window_candidates is True


def test_none_where_the_field_may_be_none():
    """A field annotated `... | None` takes none/null (rule 54's column off, from its default
    0.5), and a number still; a field that may not be None refuses the word."""
    assert TrackerOptions().body.column_rows == 0.5
    opt, changes = apply_option_changes(TrackerOptions(), ["body.column_rows=none"])
    assert opt.body.column_rows is None and changes == {"body.column_rows": None}
    assert parse_option_changes(["body.column_rows=NULL", "body.column_fraction=0.3"],
                                TrackerOptions()) == {"body.column_rows": None,
                                                      "body.column_fraction": 0.3}
    with pytest.raises(ConfigError, match="a number"):
        parse_option_changes(["body.slice_fraction=none"], TrackerOptions())


@pytest.mark.parametrize("item, words", [
    ("appearance.enabld=true", ["AppearanceOptions", "'enabld'", "enabled"]),
    ("apperance.enabled=true", ["no group", "'apperance'", "appearance"]),
    ("appearance=true", ["no field", "'appearance'"]),  # a group is not a field
    ("appearance.enabled=ture", ["appearance.enabled=ture", "true or false"]),
    ("appearance.enabled=1", ["true or false"]),
    ("appearance.bins=8.5", ["appearance.bins=8.5", "whole number"]),
    ("stitch.max_gap_s=soon", ["a number"]),
    ("stitch.max_gap_s=nan", ["not nan"]),
    ("stitch.max_dv_mps=0", ["stitch.max_dv_mps", "> 0"]),  # the record's own check
    ("dynamics=4d", ["dynamics", "4d"]),
    ("appearance.enabled", ["GROUP.FIELD=VALUE"]),
    ("=true", ["GROUP.FIELD=VALUE"]),
    ("appearance.enabled=", ["GROUP.FIELD=VALUE"]),
])
def test_bad_items_are_refused_with_the_item_named(item, words):
    with pytest.raises(ConfigError) as e:
        apply_option_changes(CountOptions(), [item])
    assert e.value.key == "--set"
    for w in words:
        assert w in str(e.value), str(e.value)


def test_count_applies_set_and_says_so(videos, tmp_path, capsys):  # noqa: F811
    """`verdicts.classify=false` leaves every track unclassified: observable in the counts."""
    capsys.readouterr()
    rc = main(["count", str(videos["cross"]), "-c", str(videos["config"]), "-o",
               str(tmp_path / "o"), "--fps", "15", "--json", "--no-report",
               "--set", "verdicts.classify=false", "--set", "appearance.enabled=true",
               "--set", "stitch.max_dv_mps=inf"])
    assert rc == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["option_changes"] == {"verdicts.classify": False, "appearance.enabled": True,
                                         "stitch.max_dv_mps": "inf"}  # JSON has no infinity
    c = summary["counts"]
    assert c["tracks"] == 2 and c["unclassified"] == 2 and c["pedestrians"] == 0
    on_disk = json.loads((tmp_path / "o" / "counts.json").read_text())
    assert on_disk["option_changes"] == summary["option_changes"]


def test_track_applies_set_after_the_flags(videos, tmp_path, capsys):  # noqa: F811
    """--no-window-candidates, then --set body.window_candidates=true: the candidate columns are
    written, and the summary names the change."""
    capsys.readouterr()
    out = tmp_path / "t.csv"
    rc = main(["track", str(videos["cross"]), "-c", str(videos["config"]), "-o", str(out),
               "--fps", "15", "--json", "--no-window-candidates", "--set",
               "body.window_candidates=true"])
    assert rc == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["option_changes"] == {"body.window_candidates": True}
    header = next(csv.reader(out.read_text().splitlines()))
    assert {"intensity_up20", "intensity_up10", "intensity_down10"} <= set(header)
