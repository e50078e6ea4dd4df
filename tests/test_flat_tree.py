"""`model.flat_tree`: split/join round trip, interning of equal structures, and the interning table
bounded by what is alive (issue 14: it was an unbounded module-level dict)."""

from __future__ import annotations

import gc

import numpy as np

from rhythmjax.model.flat_tree import interned_count, join, split
from rhythmjax.model.params import Config, config_from_dict


def test_split_join_round_trip():
    cfg = Config()
    leaves, structure = split(cfg)
    back = join(leaves, structure)
    for a, b in zip(split(back)[0], leaves):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    assert float(back.camera.h) == float(cfg.camera.h)


def test_equal_structures_are_one_object():
    _, s1 = split(Config())
    _, s2 = split(Config())
    assert s1 is s2


def test_table_does_not_outgrow_live_structures():
    gc.collect()
    before = interned_count()
    held = [split(config_from_dict({"camera": {"image_width_px": 100 + k}}))[1]
            for k in range(50)]
    assert interned_count() == before + 50
    del held
    gc.collect()
    assert interned_count() == before
    # array leaves do not enter the structure: configs differing only in values share one
    leaves_a, sa = split(config_from_dict({"camera": {"h_m": 3.0}}))
    leaves_b, sb = split(config_from_dict({"camera": {"h_m": 4.0}}))
    assert sa is sb and len(leaves_a) == len(leaves_b) > 1
