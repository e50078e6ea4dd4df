"""Rule 37 (`track.twice`, `size.twice_pace_heights`, on by default since issue 16's
thirty-eighth round): a window refused by (14) whose strongest peak passes (14) at half its
frequency and twice the step is Pedestrian there (reason matched-twice) when its rows are as
tall as a walker. Hand-worked cases against Table
1's walking model (pace 2.05 +- 3 x 0.183 Hz = [1.501, 2.599], step 0.72 +- 3 x 0.09 m = [0.45,
0.99]; P_thr 10, R_thr 0.1), and the tracker on a rendered walker going away from the camera."""

from types import SimpleNamespace

import numpy as np
import pytest

from rhythmjax.model.camera_np import camera_tuple, project_3d
from rhythmjax.model.params import Config, config_from_dict
from rhythmjax.model.status import Reason, TrackState, Verdict
from rhythmjax.sim.evaluate import score
from rhythmjax.sim.presets import SCENE_OPTIONS, SYNTHETIC_CONFIG, synthetic_options
from rhythmjax.sim.scene import random_spec, render_scene
from rhythmjax.track import track_frames
from rhythmjax.track.options import SizeOptions, with_changes
from rhythmjax.track.recheck import switch_row
from rhythmjax.track.rows import TrackRow
from rhythmjax.track.toolkit import match_window
from rhythmjax.track.twice import judge_at_half, second_look


CFG = Config()
ON = SizeOptions(twice_pace_heights=0.75)  # the a priori value (the default: the fitted 0.57)


def object_rows(top_m: float, n: int = 12) -> list[TrackRow]:
    """n measured rows of an object at 25-30 m in front of the paper's camera (a walker's head
    inside the image there) whose top is `top_m` m above its feet."""
    y = np.linspace(25.0, 30.0, n)
    u, v = project_3d(CFG.camera, 0 * y, y, 0 * y)
    _, v_top = project_3d(CFG.camera, 0 * y, y, top_m + 0 * y)
    return [TrackRow(i, i / 15, float(a), float(b), 20.0, 1.0, 0.0, float(c), 2, float(d))
            for i, (a, b, c, d) in enumerate(zip(u, v, y, v_top))]


def refused_window(f1=4.0, p1=40.0, ratio=0.8, speed=1.4, reason=Reason.NO_MODEL_MATCH):
    """A window's outcome refused by (14), its strongest peak f1 Hz with power p1."""
    return {"verdict": np.asarray(int(Verdict.NON_PEDESTRIAN)), "reason": np.asarray(int(reason)),
            "pace_hz": np.asarray(f1), "stride_m": np.asarray(speed / f1),
            "ratio": np.asarray(ratio), "speed_mps": np.asarray(speed),
            "peak_freq": np.asarray([f1, 1.0]), "peak_power": np.asarray([p1, 5.0]),
            "peak_mask": np.asarray([True, True])}


def test_a_walker_at_twice_its_pace_is_judged_at_half():
    """4.0 Hz at 1.4 m/s: (14) refuses 4.0 Hz, 0.35 m and accepts 2.0 Hz, 0.70 m; the rows read
    1.7 m, above 0.75 x 1.7 = 1.275 m."""
    out = judge_at_half(refused_window(), CFG, object_rows(1.7), CFG.camera, 1.7, ON)
    assert int(out["verdict"]) == Verdict.PEDESTRIAN and int(out["reason"]) == Reason.MATCHED_TWICE
    assert float(out["pace_hz"]) == pytest.approx(2.0)
    assert float(out["stride_m"]) == pytest.approx(0.7)
    assert float(out["ratio"]) == pytest.approx(0.8)  # (15) of the peak itself


@pytest.mark.parametrize("why, out, top_m, n, options", [
    ("off", refused_window(), 1.7, 12, SizeOptions(twice_pace_heights=0.0)),
    ("a dog's height", refused_window(), 0.6, 12, ON),
    ("1.27 m, just below 0.75 walker heights", refused_window(), 1.27, 12, ON),
    ("too few rows to read a height", refused_window(), 1.7, 9, ON),
    ("half of 6 Hz is no pace", refused_window(f1=6.0), 1.7, 12, ON),
    ("twice 0.58 m at 2.3 m/s is no step", refused_window(speed=2.3), 1.7, 12, ON),
    ("the peak below P_thr", refused_window(p1=9.0), 1.7, 12, ON),
    ("its R below R_thr", refused_window(ratio=0.05), 1.7, 12, ON),
    ("refused by (15), not (14)", refused_window(reason=Reason.BELOW_THRESHOLD), 1.7, 12, ON),
])
def test_the_verdict_stands(why, out, top_m, n, options):
    assert judge_at_half(out, CFG, object_rows(top_m, n), CFG.camera, 1.7, options) is out, why


def test_a_peak_inside_the_model_is_not_halved():
    """2.0 Hz at 1.4 m/s passes (14) itself: the rule is for windows (14) refused."""
    out = refused_window(f1=2.0)
    assert judge_at_half(out, CFG, object_rows(1.7), CFG.camera, 1.7, ON) is out


def _walker_going_away(look=None, n: int = 128, pace_after: float = 4.0) -> SimpleNamespace:
    """n rows of a 1.7 m walker going away from 22 m at 1.3 m/s in front of the paper's camera
    (its head inside the image, its top row measured), I(k) a sine at 2.0 Hz over the first 64
    rows and at `pace_after` Hz after them (4.0: twice its pace), amplitude 5, plus noise of
    1.0 (a nearly pure sine puts Burg's peak near P_thr, phase by phase); `look`: the object's
    `second_look` (None: without rule 37)."""
    rng = np.random.default_rng(0)
    t = np.arange(n) / 15.0
    y = 22.0 + 1.3 * t
    u, v = project_3d(CFG.camera, 0 * y, y, 0 * y)
    _, v_top = project_3d(CFG.camera, 0 * y, y, 1.7 + 0 * y)
    pace = np.where(np.arange(n) < 64, 2.0, pace_after)
    sig = 20.0 + 5.0 * np.sin(2 * np.pi * np.cumsum(pace) / 15.0) + rng.normal(0, 1.0, n)
    rows = [TrackRow(k, float(t[k]), float(u[k]), float(v[k]), 20.0, float(sig[k]), 0.0,
                     float(y[k]), int(TrackState.OBSERVE), float(v_top[k])) for k in range(n)]
    return SimpleNamespace(rows=rows, win_start=0, windows_done=0, result=None, decided=False,
                           second_look=look)


def _judged_online(obj):
    """`obj` after its windows judged as online, until one says Pedestrian."""
    while not obj.decided and len(obj.rows) >= obj.win_start + CFG.thresholds.n:
        match_window(CFG, obj)
    return obj


def test_rule_29_reads_later_windows_with_rule_37():
    """A walker judged Pedestrian at 2.0 Hz in rows 0-64 whose later windows read 4.0 Hz: rule
    29's recheck (`recheck.switch_row`) refuses a later window above the fastest pace (2.599
    Hz) and cuts the track at row 64; for an object with rule 37's second look (the tracker's)
    that window is the walk at 2.0 Hz (matched-twice) and the track is not cut. A later window
    at 6.0 Hz (half of it, 3.0 Hz, no pace either) is cut with or without it."""
    look = second_look(CFG, camera_tuple(CFG.camera), ON)
    plain, seen = _judged_online(_walker_going_away()), _judged_online(_walker_going_away(look))
    for obj in (plain, seen):
        assert obj.result["window"] == (0, 64) and int(obj.result["reason"]) == Reason.MATCHED
    assert switch_row(CFG, plain) == 64
    assert switch_row(CFG, seen) is None
    later = _walker_going_away(look)
    later.win_start = 64
    match_window(CFG, later)
    assert int(later.result["reason"]) == Reason.MATCHED_TWICE
    assert float(later.result["pace_hz"]) == pytest.approx(2.0, abs=0.05)
    fast = _judged_online(_walker_going_away(look, pace_after=6.0))
    assert switch_row(CFG, fast) == 64


def test_the_tracker_judges_a_walker_going_away_at_its_pace():
    """Own knees scene (`eval_synthetic`'s scene 5 of seed 2070001): walker ped001 walks away
    from the camera at 2.07 Hz. Its first window reads its pace, its later ones 4.14 Hz (two
    bursts a step): without rule 37, rule 29 cuts the track at its second window and the longer
    piece, judged afresh, is Non-pedestrian; with it, that window is the walk at half its peak,
    the track stays whole and is judged Pedestrian at 2.07 +- 0.05 Hz. Nothing else in the scene
    is judged Pedestrian that was not before."""
    cfg = config_from_dict(SYNTHETIC_CONFIG)
    seed = 2070001 + 5000
    spec = random_spec(seed, n_walkers=3, n_bicycles=1, n_dogs=0, n_frames=180,
                       camera=cfg.camera, articulated=True, **SCENE_OPTIONS)
    scene = render_scene(seed, spec)
    verdicts_by = {}
    for h in (0.0, 0.75):
        opts = with_changes(synthetic_options(), {"size.twice_pace_heights": h})
        frames = ((i, i / scene.fps, f) for i, f in enumerate(scene.frames))
        tracks, verdicts, _, _ = track_frames(cfg, frames, progress=False, options=opts)
        verdicts_by[h] = ({o["object"]: o for o in score(tracks, verdicts, scene.truth)["objects"]},
                          verdicts)
    off, on = verdicts_by[0.0][0], verdicts_by[0.75][0]
    assert off["ped001"]["verdict"] == "non-pedestrian" and off["ped001"]["tracks"] == 2
    assert on["ped001"]["verdict"] == "pedestrian" and on["ped001"]["tracks"] == 1
    assert abs(on["ped001"]["pace"] - on["ped001"]["pace_true"]) < 0.05
    for name, o in on.items():
        if o["verdict"] == "pedestrian":
            assert o["kind"] == "pedestrian", name


def test_a_negative_height_is_refused():
    with pytest.raises(ValueError, match="twice_pace_heights"):
        SizeOptions(twice_pace_heights=-0.5)
