"""Populations for the self-calibration tests (`fit.selfcal`): walkers drawn by
`rhythmjax.sim.tracks` with one property changed, seen by a known camera."""

from __future__ import annotations

import numpy as np
import pytest

from fit.walking import make_labelled
from rhythmjax.io import write_table


def strolling_params(draw, pace_hz: float):
    """A `sim_tracks.kind_params` whose walkers step at N(pace_hz, 0.12^2) Hz (clipped to
    1.5-2.1) with steps of 0.72 F / 2.05 m (a constant walk ratio: short steps when slow);
    other kinds as `draw` gives them."""

    def strolling(kind, rng, size=None):
        if kind != "pedestrian":
            return draw(kind, rng, size)
        pace = np.clip(rng.normal(pace_hz, 0.12, size), 1.5, 2.1)
        stride = 0.72 * pace / 2.05
        if size is None:
            pace, stride = float(pace), float(stride)
        return pace, stride, pace * stride, (1.0 if size is None else np.ones(size))

    return strolling


def walkers_with(camera, patch, n_walkers: int = 20, seed: int = 5):
    """(columns, truth) of `n_walkers` walkers seen by `camera`, drawn while `patch(mp)` has
    changed the simulator (a `pytest.MonkeyPatch`), undone afterwards."""
    mp = pytest.MonkeyPatch()
    patch(mp)
    try:
        return make_labelled(n_walkers=n_walkers, n_bicycles=0, n_dogs=0, n_cars=0, seed=seed,
                             camera=camera)
    finally:
        mp.undo()


def three_track_command(tmp_path, cols) -> list[str]:
    """`rhythmjax-fit selfcal` arguments on the first three tracks of `cols` (written with
    their top rows to TMP/tracks.parquet): too few walkers, so the command asks the fit and
    refuses (exit 1), which lets a test see what reached `fit_selfcal`."""
    keep = np.isin(cols["track_id"], np.unique(cols["track_id"])[:3])
    path = tmp_path / "tracks.parquet"
    names = ["track_id", "frame", "t", "u", "v", "width_px", "intensity", "v_top"]
    write_table(path, {k: np.asarray(cols[k])[keep] for k in names}, names)
    return ["selfcal", str(path), "--image-size", "1280x720", "--fps", "15",
            "-o", str(tmp_path / "cam.json")]


__all__ = ["strolling_params", "three_track_command", "walkers_with"]
