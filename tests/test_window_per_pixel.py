"""Rule 35 (issue 16): I(k) as the mean of the frame difference D over window B (grey levels per
pixel) instead of its sum, in the online tracker (`body.window_per_pixel`), its candidate and
pace windows, and the `rhythm` verb (`--window-per-pixel`).

References: the windows' pixels counted by hand, and, on a drawn scene, the per-pixel samples
times the clipped window's area (`window_b_rect`, recomputed here) against the summed samples
of a second run. Tolerance: 1e-9 relative (a float sum divided and multiplied by an integer).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rhythmjax.cli.main import main as cli_main
from rhythmjax.io import read_table
from rhythmjax.model.params import Config
from rhythmjax.sim import scene as synth
from rhythmjax.track import track_frames
from rhythmjax.track.boxes import box_intensities, window_widths
from rhythmjax.track.options import BodyOptions, TrackerOptions
from rhythmjax.vision.window_b import window_b_candidates, window_b_extras, window_b_intensity

from .helpers import write_clip_and_truth_boxes


def test_per_pixel_windows_by_hand():
    """D: ones in rows 21..23 and threes in row 24, columns 10..29 (40 x 50). W 10 px: window B
    is 10 columns (15..24) by 2 rows ending at the foot row; the pace window at scale 2 is 20
    columns (10..29) by 4 rows. Means: the hand counts of the sums divided by those areas."""
    D = np.zeros((40, 50), np.uint8)
    D[21:24, 10:30] = 1
    D[24, 10:30] = 3
    assert window_b_intensity(D, 20.0, 25.0, 10.0, mean=True) == 30.0 / 20
    assert window_b_candidates(D, 20.0, 25.0, 10.0, (0.0, -0.1, -0.2), mean=True) == \
        (30.0 / 20, 40.0 / 20, 20.0 / 20)
    # pace window: rows 22..25, columns 10..29: 20 + 20 + 60 = 100 over 80 px
    assert window_b_extras(D, 20.0, 25.0, 10.0, (-0.1,), 2.0, mean=True) == (40.0 / 20,
                                                                            100.0 / 80)
    # clipped at the left border (u 2, W 10: columns 0..6), where D is 0
    assert window_b_intensity(D, 2.0, 25.0, 10.0, mean=True) == 0.0
    assert math.isnan(window_b_intensity(D, math.nan, 25.0, 10.0, mean=True))


@pytest.fixture(scope="module")
def walker_scene():
    """One walker coming towards the camera from 14 to 6 m (its window B grows ~2.3 times)."""
    spec = synth.SceneSpec(n_frames=90, actors=(synth.walker(0.3, 14.0, -math.pi / 2,
                                                             pace_hz=2.0, step_length_m=0.7),))
    return synth.render_scene(5, spec)


def _track(scene, per_pixel: bool, pace: float = 0.0):
    opt = TrackerOptions(body=BodyOptions(window_per_pixel=per_pixel, pace_window_widths=pace))
    frames = ((i, i / scene.fps, f) for i, f in enumerate(scene.frames))
    return track_frames(Config(), frames, progress=False, options=opt)


def test_tracker_samples_per_pixel(walker_scene):
    """The same track both ways (window B's sampling never moves the filter); per row the sum
    over the mean is window B's clipped area, a whole number of pixels that grows with the
    walker's image: from 14 to 6 m about (14 / 6)^2 = 5.4 times (W and W/5 both scale). The
    candidate and pace windows are sampled per pixel too."""
    summed, _, _, _ = _track(walker_scene, False, pace=2.0)
    mean, _, _, _ = _track(walker_scene, True, pace=2.0)
    for k in ("track_id", "frame", "u", "v", "x_est", "y_est"):
        np.testing.assert_array_equal(summed[k], mean[k])
    ok = np.isfinite(summed["intensity"]) & (mean["intensity"] > 0)
    assert ok.sum() > 60
    area = summed["intensity"][ok] / mean["intensity"][ok]
    np.testing.assert_allclose(area, np.round(area), rtol=0, atol=1e-6)
    y = summed["y_est"][ok]
    near, far = area[y < np.quantile(y, 0.1)].mean(), area[y > np.quantile(y, 0.9)].mean()
    want = (np.quantile(y, 0.95) / np.quantile(y, 0.05)) ** 2
    assert 0.6 * want < near / far < 1.4 * want
    for c in ("intensity_up20", "intensity_up10", "intensity_down10", "intensity_wide"):
        both = np.isfinite(summed[c])
        assert np.all(both == np.isfinite(mean[c]))
        assert np.all(mean[c][both] * 4 <= summed[c][both] + 1e-9)  # every window >= 4 px


def test_rhythm_verb_flag(walker_scene, tmp_path):
    """`rhythm --window-per-pixel` samples the boxes' windows per pixel: its intensity is
    `box_intensities(..., mean=True)`'s; `--no-window-per-pixel` the sum's."""
    import cv2

    video, gt = write_clip_and_truth_boxes(walker_scene, tmp_path)
    cap = cv2.VideoCapture(video)
    decoded = []
    while True:
        ok, f = cap.read()
        if not ok:
            break
        decoded.append(f[:, :, 0])
    for flag, per_pixel in (("--window-per-pixel", True), ("--no-window-per-pixel", False)):
        d = tmp_path / flag.strip("-")
        assert cli_main(["rhythm", video, "--boxes", str(gt), "-o", str(d),
                         "-q", "--no-camera-check", flag]) == 0
        got = read_table(str(d / "tracks.parquet"))
        u, v = np.asarray(got["u"], float), np.asarray(got["v"], float)
        W = window_widths(Config(), u, v)
        frames = ((i, i / 15.0, f) for i, f in enumerate(decoded))
        want = box_intensities(frames, np.asarray(got["frame"]), u, v, W,
                               mean=per_pixel).intensity
        np.testing.assert_allclose(np.asarray(got["intensity"], float), want, rtol=1e-9,
                                   equal_nan=True)
        assert np.nanmax(want) < (255.0 if per_pixel else np.inf)
