"""The annotated video's frames (`cli.overlay`): colour by verdict, labels in words, every label
inside the frame and none overlapping another or the legend (checked on the computed boxes),
the trail of foot points, the same style for `count`; drawn on the video's own colour frame
(checked bit for bit against an independent OpenCV decode) where it has one, grey otherwise."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from rhythmjax.cli.overlay import (
    PALETTE,
    TRAIL,
    FrameSampler,
    TrackOverlay,
    in_colour,
    label_text,
    place_labels,
    text_box_size,
)
from rhythmjax.vision.video import open_video


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


# -- the video's own colours --------------------------------------------------------------------
SQUARE = (slice(12, 36), slice(12, 36))  # inside the blue square, away from labels and legend


def _video(path, colour: bool, n: int = 24, w: int = 256, h: int = 192):
    """A video written with OpenCV (MJPG .avi, 15 fps): a grey ramp, a saturated blue square at
    the top left (`colour`; grey 128 otherwise) and a dark block in the middle."""
    vw = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 15.0, (w, h), True)
    for _ in range(n):
        img = cv2.cvtColor(np.repeat(np.linspace(60, 180, w).astype(np.uint8)[None], h, 0),
                           cv2.COLOR_GRAY2BGR)
        img[8:40, 8:40] = (230, 40, 20) if colour else (128, 128, 128)
        img[80:130, 120:140] = 40
        vw.write(img)
    vw.release()
    return path


def _decoded(path) -> list[np.ndarray]:
    """Every frame as OpenCV decodes it (BGR): the reference for the colours kept."""
    cap, out = cv2.VideoCapture(str(path)), []
    while True:
        ok, f = cap.read()
        if not ok:
            return out
        out.append(f)


OBJ = [{"track_id": 1, "u": 130.0, "v": 130.0, "width": 20.0, "state": "observe",
        "verdict": "pedestrian"}]


def test_overlay_draws_on_the_colour_frame_the_pipeline_sees_grey(tmp_path):
    path = _video(tmp_path / "colour.avi", colour=True)
    ref = _decoded(path)
    src = open_video(path, fps=15)
    assert src.is_colour
    pick, draw = in_colour(src), TrackOverlay("run")
    n = 0
    for index, _, gray in src:
        assert gray.ndim == 2 and gray.dtype == np.uint8  # the pipeline stays grey
        img = draw(pick(gray, index), index, OBJ)
        # the square's pixels are the decoded colour frame's, bit for bit
        np.testing.assert_array_equal(img[SQUARE], ref[index][SQUARE])
        b, g, r = (float(img[SQUARE][..., c].mean()) for c in range(3))
        assert b > 180 and g < 90 and r < 90, (b, g, r)
        n += 1
    assert n == len(ref) == 24
    assert src.colour(0) is None  # taken once; nothing left behind
    # not kept: grey frames as before
    src2 = open_video(path, fps=15)
    index, _, gray = next(iter(src2))
    assert src2.colour(index) is None
    assert np.ptp(draw(gray, index, OBJ)[SQUARE], axis=-1).max() == 0


def test_grey_source_stays_grey(tmp_path):
    path = _video(tmp_path / "grey.avi", colour=False)
    src = open_video(path, fps=15)
    assert not src.is_colour
    pick = in_colour(src)
    index, _, gray = next(iter(src))
    assert pick(gray, index) is gray
    img = TrackOverlay("run")(pick(gray, index), index, OBJ)
    assert np.ptp(img[SQUARE].astype(int), axis=-1).max() == 0  # B = G = R
    folder = tmp_path / "frames"  # a folder of grey PNGs
    folder.mkdir()
    for k in range(3):
        cv2.imwrite(str(folder / f"{k}.png"), gray)
    src = open_video(folder, fps=15)
    pick = in_colour(src)
    assert not src.is_colour and all(pick(g, i) is g for i, _, g in src)


def test_colour_frames_kept_only_until_taken(tmp_path):
    """Frames read ahead (count's background peek) wait; a frame taken drops the older ones."""
    path = _video(tmp_path / "colour.avi", colour=True, n=6)
    src = open_video(path, fps=15)
    src.keep_colour = True
    items = list(src)
    assert src.colour(3) is not None
    assert src.colour(1) is None and src.colour(2) is None  # older than 3: dropped
    assert src.colour(5) is not None and src.colour(4) is None
    assert len(items) == 6


def test_count_overlay_video_keeps_the_colours(tmp_path):
    """`rhythmjax count --overlay` on a colour video writes colour frames; on a grey one, grey
    frames (MJPG both ways: channels within 12 grey levels of the source's)."""
    from rhythmjax.cli.main import main

    from .test_pedestrians import SMALL

    cfg = tmp_path / "small.json"
    cfg.write_text(json.dumps(SMALL))
    for colour in (True, False):
        video = _video(tmp_path / f"v{colour}.avi", colour=colour, n=20)
        out, ov = tmp_path / f"out{colour}", tmp_path / f"ov{colour}.avi"
        assert main(["count", str(video), "-c", str(cfg), "-o", str(out), "--fps", "15", "-q",
                     "--overlay", str(ov), "--no-camera-check"]) == 0
        frames = _decoded(ov)
        assert len(frames) == 20
        b, g, r = (float(frames[10][SQUARE][..., c].mean()) for c in range(3))
        if colour:
            assert b > 180 and g < 90 and r < 90, (b, g, r)
        else:
            assert max(abs(b - 128), abs(g - 128), abs(r - 128)) < 12, (b, g, r)
            top = frames[10][:60].astype(int)  # the ramp and square, no annotation
            assert np.ptp(top, axis=-1).max() <= 12
