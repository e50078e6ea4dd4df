"""Pipeline regression: a small fixed-seed set of synthetic scenes through the whole pipeline
(render -> detect -> online tracker with the demo's options -> rhythm windows -> evaluate.score,
each object's verdict from the rhythm windows that looked at it) must not score worse than the
stored baseline (tests/pipeline_baseline.json) beyond the stated margins:

- walker Pedestrian rate: at most MARGIN_RATE below the baseline (one walker of the 14);
- bicycles and dogs judged Non-pedestrian: at most one fewer; judged Pedestrian: none more;
- pace MAE: at most MARGIN_PACE_HZ above the baseline;
- step-length median error: at most MARGIN_STRIDE_M above the baseline.

Regenerate the baseline (after a deliberate improvement) with
`RHYTHMJAX_WRITE_BASELINE=1 pytest tests/test_pipeline_regression.py`.
"""

import json
import math
import os
from pathlib import Path

from rhythmjax.model.params import config_from_dict
from rhythmjax.sim.evaluate import deciding_windows, score, summarise
from rhythmjax.sim.presets import SYNTHETIC_CONFIG, SYNTHETIC_OPTIONS, synthetic_options
from rhythmjax.sim.scene import random_spec, render_scene
from rhythmjax.track.tracker import OnlineTracker


BASELINE = Path(__file__).with_name("pipeline_baseline.json")
CONFIG = SYNTHETIC_CONFIG  # the demo's config
SEEDS = (101, 202, 303, 404)
MARGIN_RATE = 0.075
MARGIN_PACE_HZ = 0.01
MARGIN_STRIDE_M = 0.01  # (12) with a least-squares speed: 0.026 m here; Theil-Sen of the
# filtered positions: 0.022 m; of the accepted measured foot points (`rhythm.window_speed`): 0.013 m


def _figures() -> dict:
    cfg = config_from_dict(CONFIG)
    rows = []
    for i, seed in enumerate(SEEDS):
        spec = random_spec(seed, n_walkers=4 if i < 2 else 3, n_bicycles=1 if i % 2 else 0,
                           n_dogs=0 if i % 2 else 1, n_frames=150, camera=cfg.camera,
                           min_life=100, max_life=140, bicycle_speed=(3.0, 3.4),
                           range_m=(3.3, 19.7))
        scene = render_scene(seed, spec)
        tr = OnlineTracker(cfg, synthetic_options())
        for k, f in enumerate(scene.frames):
            tr.update(k, k / scene.fps, f)
        tracks, verdicts, objs = tr.finish()
        rows += score(tracks, verdicts, scene.truth, windows=deciding_windows(objs))["objects"]
    out = summarise(rows)
    out["others_pedestrian"] = sum(r["kind"] != "pedestrian" and r["verdict"] == "pedestrian"
                                   for r in rows)
    return out


def test_pipeline_not_worse_than_baseline():
    got = _figures()
    keys = ("walkers", "walkers_pedestrian", "walker_pedestrian_rate", "others",
            "others_judged", "others_non_pedestrian", "others_pedestrian", "pace_mae_hz",
            "stride_median_err_m")
    if os.environ.get("RHYTHMJAX_WRITE_BASELINE"):
        BASELINE.write_text(json.dumps({"config": CONFIG, "options": SYNTHETIC_OPTIONS,
                                        "seeds": list(SEEDS),
                                        **{k: got[k] for k in keys}}, indent=1) + "\n")
    base = json.loads(BASELINE.read_text())
    assert got["walkers"] == base["walkers"] and got["others"] == base["others"]
    assert got["walker_pedestrian_rate"] >= base["walker_pedestrian_rate"] - MARGIN_RATE, got
    assert got["others_non_pedestrian"] >= base["others_non_pedestrian"] - 1, got
    assert got["others_pedestrian"] <= base["others_pedestrian"], got
    assert math.isfinite(got["pace_mae_hz"])
    assert got["pace_mae_hz"] <= base["pace_mae_hz"] + MARGIN_PACE_HZ, got
    assert got["stride_median_err_m"] <= base["stride_median_err_m"] + MARGIN_STRIDE_M, got
