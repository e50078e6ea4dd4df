"""benchmarks/study_track_ends.py: a piece's owner and the output track holding it, against
boxes worked by hand, and the study on one small rendered scene (every piece's end reason is one
of `END_REASONS`, the reasons add up to the summary's `ends`)."""

from __future__ import annotations

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np


BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))
import study_track_ends as ends  # noqa: E402

from rhythmjax.count.rows import BoxRow  # noqa: E402


def _truth():
    # walker 7 at left 100, top 50, 20 x 60 in frames 10-13 (truth frame = index + 1 + offset
    # 0, the MOT numbering);
    # cyclist 8 far to the right
    f = np.array([11, 12, 13, 14, 11, 12, 13, 14])
    return {"frame": f, "id": np.array([7] * 4 + [8] * 4),
            "bb_left": np.array([100.0] * 4 + [300.0] * 4), "bb_top": np.full(8, 50.0),
            "bb_width": np.full(8, 20.0), "bb_height": np.full(8, 60.0)}


def _box(frame, left):
    return BoxRow(frame, left, 50.0, 20.0, 60.0, 1.0, 0.0, 5.0, True)


def test_piece_owner_by_majority_of_iou_03():
    kinds = {7: "pedestrian", 8: "bicycle"}
    # 3 of 4 boxes on walker 7: IoU 1, (20-5)/(20+5) = 0.6, 0.6; the 4th on nothing
    on = [_box(10, 100.0), _box(11, 105.0), _box(12, 95.0), _box(13, 200.0)]
    assert ends.piece_owner(on, _truth(), 0, kinds) == (7, "pedestrian")
    # shifted 14 px: IoU 6/34 = 0.18 < 0.3 in every frame: nobody
    assert ends.piece_owner([_box(k, 114.0) for k in range(10, 14)], _truth(), 0,
                            kinds) == (None, None)
    # 1 of 4 on the cyclist: under half: nobody
    half = [_box(10, 300.0), _box(11, 200.0), _box(12, 200.0), _box(13, 200.0)]
    assert ends.piece_owner(half, _truth(), 0, kinds) == (None, None)
    # 2 of 4: half is enough
    half = [_box(10, 300.0), _box(11, 300.0), _box(12, 200.0), _box(13, 200.0)]
    assert ends.piece_owner(half, _truth(), 0, kinds) == (8, "bicycle")


def test_truth_frames_follow_owner_of_tracks():
    # own scenes number the truth from 0 (offset -1), dev clips from 1 (offset 0)
    assert ends.truth_frame(0, -1) == 0 and ends.truth_frame(0, 0) == 1
    # a shifted numbering finds nobody: the boxes meet frames where walker 7 is absent
    on = [_box(k, 100.0) for k in range(10, 14)]
    assert ends.piece_owner(on, _truth(), 0, {7: "pedestrian", 8: "bicycle"})[0] == 7
    assert ends.piece_owner(on, _truth(), 4, {7: "pedestrian", 8: "bicycle"})[0] is None


def test_final_tracks_find_each_piece_by_its_first_box():
    mot = {"frame": np.array([11, 12, 31, 32]), "id": np.array([1, 1, 2, 2]),
           "bb_left": np.array([100.0, 101.0, 50.0, 51.0]),
           "bb_top": np.array([50.0, 50.0, 40.0, 40.0])}
    res = SimpleNamespace(mot=mot)
    keys = [(10, 100.0, 50.0), (30, 50.0, 40.0), (11, 101.0, 50.0), (10, 100.5, 50.0)]
    # index frame 10 is MOT frame 11; a piece whose first box is not in the output: 0
    assert ends.final_tracks(res, keys) == [1, 2, 1, 0]


def test_study_on_one_scene_accounts_for_every_piece():
    from rhythmjax.count import CountOptions
    from rhythmjax.count.pedestrian_level import END_REASONS
    from rhythmjax.sim.scene import SceneSpec, render_scene, walker

    from .test_pedestrians import CFG, QUIET

    a = walker(-4.0, 7.0, 0.0, start_frame=3, phase=0.1)
    b = walker(4.0, 7.6, np.pi, start_frame=3, phase=0.6, grey_torso=150, grey_legs=70)
    scene = render_scene(1, SceneSpec(n_frames=72, actors=(a, b), camera=CFG.camera))
    truth = {"frame": [], "id": [], "bb_left": [], "bb_top": [], "bb_width": [],
             "bb_height": []}
    for i, tr in enumerate(scene.truth):  # a box 0.5 m wide, 1.7 m tall at each foot point,
        # numbered from 0 like the own counting scenes' truth (offset -1)
        for k in np.flatnonzero(tr.visible):
            w = 25000.0 * 0.008 * 0.5 / 7.0
            for key, val in zip(truth, (k, i, tr.u[k] - w / 2, tr.v[k] - 3.4 * w, w, 3.4 * w)):
                truth[key].append(val)
    truth = {k: np.asarray(v) for k, v in truth.items()}
    frames = [(k, k / 15.0, f) for k, f in enumerate(scene.frames)]
    rows, res, pairs = ends.study_clip("scene", CFG, frames, truth, {0: "pedestrian",
                                       1: "pedestrian"}, -1, CountOptions(verdicts=QUIET), 1.0)
    assert all(r[4] in END_REASONS for r in rows)
    assert sum(res.summary["ends"].values()) == len(rows) == 2
    assert sorted(r[5] for r in rows) == [0, 1]  # one piece on each walker, both to the end
    assert all(r[4] == "clip-end" and not r[7] for r in rows) and pairs == []
    assert sorted(r[10] for r in rows) == [1, 2]
    assert all(r[12:] == [0, 0] for r in rows)  # option off: no rewind


def test_rewind_fate_and_summary_by_hand():
    from rhythmjax.model.status import TrackState
    from rhythmjax.track.rows import TrackRow

    def row(k, state):
        return TrackRow(k, k / 15.0, 1.0, 1.0, 1.0, 1.0, 0.0, 5.0, int(state))

    obs, pred = TrackState.OBSERVE, TrackState.PREDICT
    p = SimpleNamespace(rewind_times=[], rows=[row(k, obs) for k in range(30)])
    assert ends.rewind_fate(p) == (0, 0)
    # rewound at frames 10 and 20 (t 0.667, 1.333 s); after 20: frames 21-29, 3 of them predicted
    p.rewind_times = [10 / 15.0, 20 / 15.0]
    p.rows = p.rows[:21] + [row(k, pred if k in (22, 23, 29) else obs) for k in range(21, 30)]
    assert ends.rewind_fate(p) == (2, 6)
    # rows as study_clip's: reason at 4, rewinds at 12, measured after at 13
    rows = [[None] * 4 + [why] + [None] * 7 + [n, m] for why, n, m in
            (("timeout", 2, 3), ("timeout", 1, 20), ("clip-end", 4, 15), ("timeout", 0, 0))]
    assert ends.rewind_summary(rows) == (
        "rewound pieces 3 (once 1, twice 1, 3+ 1); by end, with >= 15 measured rows after the "
        "last rewind: clip-end 1 (1), timeout 2 (1)")
