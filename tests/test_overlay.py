"""The annotated video's frames (`cli.overlay`): colour by verdict, labels in words, every label
inside the frame and none overlapping another or the legend (checked on the computed boxes),
the trail of foot points, the same style for `count`."""

from __future__ import annotations

import numpy as np
import pytest

from rhythmjax.cli.overlay import (
    PALETTE,
    TRAIL,
    FrameSampler,
    TrackOverlay,
    label_text,
    place_labels,
    text_box_size,
)


def _disjoint(boxes) -> bool:
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            if a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]:
                return False
    return True


def _inside(box, w, h) -> bool:
    return 0 <= box[0] < box[2] <= w and 0 <= box[1] < box[3] <= h


def _crowd(n=10, seed=0, w=512, h=512):
    """Objects crowded together and at every edge (labels would leave the frame unclamped)."""
    rng = np.random.default_rng(seed)
    edge = [(3.0, 40.0), (w - 3.0, 40.0), (w / 2, 12.0), (w - 5.0, h - 5.0), (4.0, h - 2.0)]
    objs = []
    for k in range(n):
        u, v = edge[k] if k < len(edge) else (rng.uniform(200, 260), rng.uniform(100, 140))
        objs.append({"track_id": k + 1, "u": u, "v": v, "width": 30.0,
                     "state": "predict" if k % 3 == 0 else "observe",
                     "verdict": (None, "pedestrian", "non-pedestrian")[k % 3]})
    return objs


@pytest.mark.parametrize("size", [(512, 512), (360, 288), (768, 576)])
def test_labels_stay_inside_the_frame_and_never_overlap(size):
    w, h = size
    draw = TrackOverlay("run")
    img = draw(np.full((h, w), 120, np.uint8), 20, _crowd(12, w=w, h=h))
    assert img.shape == (h, w, 3)  # BGR
    boxes = [b for _, _, b in draw.labels]
    assert len(boxes) + len(draw.hidden) == 12
    assert len(boxes) >= 10  # the crowd finds room for (nearly) every label
    assert all(_inside(b, w, h) for b in boxes), boxes
    assert _disjoint(boxes + [draw.legend]), boxes
    assert draw.legend[1] > h * 0.8 and draw.legend[3] == h  # a strip at the bottom


def test_labels_avoid_the_legend_strip():
    draw = TrackOverlay("run")
    objs = [{"track_id": 1, "u": 250.0, "v": 511.0, "width": 40.0, "state": "observe",
             "verdict": "pedestrian"}]
    img = draw(np.full((512, 512), 200, np.uint8), 3, objs)
    (_, _, box), = draw.labels
    assert box[3] <= draw.legend[1]  # the label sits above the legend strip
    assert np.all(img[draw.legend[1]:, 505:] < 100)  # the strip is darkened


def test_place_labels_random_scenes_property():
    rng = np.random.default_rng(3)
    for _ in range(50):
        w, h = int(rng.integers(160, 800)), int(rng.integers(120, 600))
        reqs = []
        for _ in range(int(rng.integers(1, 25))):
            x, y = rng.uniform(-40, w + 40), rng.uniform(-40, h + 40)
            bw, bh = rng.uniform(5, 60), rng.uniform(10, 120)
            reqs.append(((int(x), int(y), int(x + bw), int(y + bh)),
                         [(int(rng.integers(30, 160)), 14), (22, 14)]))
        legend = (0, h - 18, w, h)
        got = [g[0] for g in place_labels(reqs, w, h, [legend]) if g is not None]
        assert all(_inside(b, w, h) for b in got)
        assert _disjoint(got + [legend])


def test_words_and_colours_by_verdict():
    assert label_text(4, "pedestrian", "observe") == ("#4 pedestrian", "#4")
    assert label_text(7, None, "predict") == ("#7 undecided, predicted", "#7")
    assert label_text(2, "unclassified")[0] == "#2 undecided"
    assert label_text(0, None)[0] == "new"
    draw = TrackOverlay("run")
    objs = [{"track_id": 1, "u": 100.0, "v": 200.0, "width": 30.0, "state": "observe",
             "verdict": "non-pedestrian"},
            {"track_id": 2, "u": 400.0, "v": 300.0, "width": 30.0, "state": "observe",
             "verdict": "pedestrian"}]
    img = draw(np.full((512, 512), 128, np.uint8), 0, objs)
    texts = {tid: (text, box) for tid, text, box in draw.labels}
    assert texts[1][0] == "#1 non-pedestrian" and texts[2][0] == "#2 pedestrian"
    for tid, key in ((1, "non-pedestrian"), (2, "pedestrian")):
        x0, y0, x1, y1 = texts[tid][1]
        patch = img[y0:y1, x0:x1].reshape(-1, 3)
        # the label's background is the verdict's colour (most of its pixels)
        share = np.mean(np.all(patch == np.array(PALETTE[key], np.uint8), axis=1))
        assert share > 0.5, (tid, share)


def test_trail_keeps_the_last_foot_points_and_forgets_ended_tracks():
    draw = TrackOverlay("run")
    frame = np.zeros((256, 256), np.uint8)
    for k in range(TRAIL + 10):
        draw(frame, k, [{"track_id": 3, "u": 20.0 + 5 * k, "v": 100.0, "width": 10.0,
                         "state": "observe", "verdict": None}])
    pts = list(draw.trails[3])
    assert len(pts) == TRAIL and pts[-1] == (20.0 + 5 * (TRAIL + 9), 100.0)
    img = draw(frame, 99, [{"track_id": 3, "u": 150.0, "v": 100.0, "width": 10.0,
                            "state": "observe", "verdict": None}])
    assert img[100, 140:150].any()  # the trail drawn behind the foot point
    draw(frame, 100, [])
    assert 3 not in draw.trails


def test_count_overlay_same_style():
    draw = TrackOverlay("count")
    peds = [{"track_id": 0, "box": (10.0, 10.0, 20.0, 50.0), "measured": True, "verdict": None},
            {"track_id": 5, "box": (300.0, 0.0, 30.0, 80.0), "measured": False,
             "verdict": "pedestrian"},
            {"track_id": 6, "box": (-10.0, 200.0, 30.0, 80.0), "measured": True,
             "verdict": "non-pedestrian"}]
    img = draw(np.zeros((288, 360), np.uint8), 7, peds)
    assert img.shape == (288, 360, 3)
    texts = sorted(t for _, t, _ in draw.labels)
    assert texts == ["#5 pedestrian, predicted", "#6 non-pedestrian", "new"]
    assert all(_inside(b, 360, 288) for _, _, b in draw.labels)
    assert _disjoint([b for _, _, b in draw.labels])
    assert 0 not in draw.trails and 5 in draw.trails


def test_a_label_too_long_for_a_tiny_frame_falls_back_to_the_id():
    w = text_box_size("#12 non-pedestrian, predicted", 0.35)[0] - 10
    draw = TrackOverlay("run")
    draw(np.zeros((120, w), np.uint8), 0, [{"track_id": 12, "u": w / 2, "v": 60.0,
                                            "width": 8.0, "state": "predict",
                                            "verdict": "non-pedestrian"}])
    assert [t for _, t, _ in draw.labels] == ["#12"]


def test_frame_sampler_keeps_a_few_evenly_spaced_frames():
    s = FrameSampler(160, k=8, width=100)
    for i in range(160):
        s(i, np.zeros((50, 200, 3), np.uint8))
    assert [i for i, _ in s.frames] == [10 + 20 * k for k in range(8)]
    assert all(jpg[:2] == b"\xff\xd8" for _, jpg in s.frames)
