"""Rule 50b in the batch classifier (`classify`, `rhythm --boxes`, count's verdicts): a tracks
file with the columns of window B moved across (`io.files.ACROSS_COLUMNS`) is read with them
after the candidate columns (before the pace window's), and every path of `model.batch.
classify_tracks` (the fast one, the long-track one) judges them as the tracker does
(`model.candidates.judged`): checked against the same file without the columns, with a look
that refuses every window rule 37 may read, and against the tracker's own verdict on a walker
it tracked with the option on. The reader's checks too."""

from __future__ import annotations

import numpy as np
import pytest

from rhythmjax.io import BadInput, read_tracks, to_batch, write_table
from rhythmjax.io.files import ACROSS_COLUMNS, CANDIDATE_COLUMNS, PACE_COLUMN
from rhythmjax.model.batch import classify_tracks
from rhythmjax.model.params import Config
from rhythmjax.model.status import Verdict
from rhythmjax.sim.tracks import make_tracks


CFG = Config()
N = CFG.thresholds.n
GAP = max(1, round(float(CFG.thresholds.predict_timeout) * CFG.camera.fps))


def tracks_file(tmp_path, across: bool, *, pace: bool = False):
    """Walkers, bicycles, dogs and a car of `sim.tracks`; walker 0's window B and vertical
    candidates hold noise and its right-hand window its signal (the left one noise); every
    other track has its signal in every column. `across` False: those columns left out."""
    cols, _ = make_tracks(n_walkers=5, n_bicycles=2, n_dogs=2, n_cars=1, seed=50,
                          min_frames=100, max_frames=180)
    cols = {k: np.asarray(v) for k, v in cols.items()}
    signal = cols["intensity"].astype(np.float64)
    rng = np.random.default_rng(50)
    noise = np.where(np.isfinite(signal), np.nanmean(signal) * (1 + np.abs(
        rng.normal(size=len(signal)))), np.nan)
    ids = list(dict.fromkeys(cols["track_id"]))
    walker0 = [i for i in ids if str(cols["label"][cols["track_id"] == i][0]) == "pedestrian"][0]
    mine = cols["track_id"] == walker0
    cols["intensity"] = np.where(mine, noise, signal)
    for c in CANDIDATE_COLUMNS:
        cols[c] = np.where(mine, noise * 0.8, signal)
    if across:
        cols[ACROSS_COLUMNS[0]] = np.where(mine, noise * 0.5, signal)
        cols[ACROSS_COLUMNS[1]] = signal.copy()
    if pace:
        cols[PACE_COLUMN] = signal.copy()
    path = tmp_path / f"t{int(across)}.csv"
    write_table(path, cols, list(cols))
    return path, str(walker0)


def batch_of(path):
    return to_batch(read_tracks(path, fps=CFG.camera.fps), max_gap_frames=GAP, min_len=N)


@pytest.mark.parametrize("segment_rows", [10**9, 100])  # the fast path; the long-track path
def test_the_right_hand_window_decides_where_it_holds_the_gait(tmp_path, segment_rows):
    on_path, walker0 = tracks_file(tmp_path, True)
    off_path, _ = tracks_file(tmp_path, False)
    batch = batch_of(on_path)
    assert batch.across == 2 and batch.candidates.shape[-1] == len(CANDIDATE_COLUMNS) + 2
    on = classify_tracks(CFG, batch, progress=False, segment_rows=segment_rows)
    off = classify_tracks(CFG, batch_of(off_path), progress=False, segment_rows=segment_rows)
    w0 = list(on["track_id"]).index(walker0)
    assert off["verdict"][w0] != "pedestrian"  # noise in window B and the vertical candidates
    assert on["verdict"][w0] == "pedestrian" and on["candidate"][w0] == 5  # the right-hand one
    assert (np.asarray(on["verdict"]) == "pedestrian").sum() >= 4

    def refuse(res, track, start, twice=True):  # a look refusing all it may read (rule 37's)
        if not twice:
            return res
        return {**res, "verdict": np.full_like(res["verdict"], int(Verdict.NON_PEDESTRIAN))}

    looked = classify_tracks(CFG, batch, progress=False, segment_rows=segment_rows,
                             second_look=refuse)
    # only the window the right-hand window decided is looked at without it
    assert [v == "pedestrian" for v in looked["verdict"]] == \
        [i == w0 for i in range(len(on["track_id"]))]
    assert looked["candidate"][w0] == 5
    others = [i for i in range(len(on["track_id"])) if i != w0]
    for k in ("verdict", "reason", "pace_hz", "stride_m", "window_row", "candidate"):
        np.testing.assert_array_equal(np.asarray(on[k])[others], np.asarray(off[k])[others],
                                      err_msg=k)  # the same signal everywhere: ties keep B


def test_the_columns_come_together_before_the_pace_window(tmp_path):
    path, _ = tracks_file(tmp_path, True)
    import csv

    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    bad = tmp_path / "bad.csv"
    with open(bad, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=[k for k in rows[0] if k != ACROSS_COLUMNS[1]],
                           extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    with pytest.raises(BadInput, match=ACROSS_COLUMNS[1]) as err:
        read_tracks(str(bad))
    assert "bad.csv" in str(err.value)
    both = read_tracks(tracks_file(tmp_path, True, pace=True)[0])
    assert (both.across, both.pace_window, both.candidates.shape[1]) == (2, True, 6)
    np.testing.assert_array_equal(both.candidates[:, 3], [float(r[ACROSS_COLUMNS[0]]) if
                                  r[ACROSS_COLUMNS[0]] else np.nan for r in rows])
    # the right-hand window and the pace window both hold the signal; the left one does not
    np.testing.assert_array_equal(both.candidates[:, 5], both.candidates[:, 4])
    assert np.any(both.candidates[:, 3] != both.candidates[:, 4])


@pytest.mark.parametrize("segment_rows", [4096, 48])
def test_the_batch_classifier_gives_the_trackers_verdict(tmp_path, segment_rows):
    """A walker crossing the view tracked with `body.across_candidates` on, its tracks written
    with every candidate column, read back and batch-classified: the tracker's verdict, pace,
    stride and deciding window B."""
    from rhythmjax.cli.common import TRACK_ORDER
    from rhythmjax.sim import scene as synth
    from rhythmjax.track import track_frames
    from rhythmjax.track.columns import candidate_columns
    from rhythmjax.track.options import TrackerOptions, with_changes

    act = synth.walker(-3.4, 12.0, 0.0, pace_hz=1.9, step_length_m=0.62)
    sc = synth.render_scene(3, synth.SceneSpec(n_frames=130, actors=(act,), camera=CFG.camera))
    frames = ((i, i / sc.fps, f) for i, f in enumerate(sc.frames))
    opt = with_changes(TrackerOptions(), {"body.across_candidates": True})
    tracks, verdicts, _, _ = track_frames(CFG, frames, progress=False, options=opt)
    path = tmp_path / "tracks.csv"
    write_table(str(path), tracks, TRACK_ORDER + candidate_columns(tracks))
    back = read_tracks(str(path), fps=CFG.camera.fps)
    assert back.across == 2 and not back.pace_window
    again = classify_tracks(CFG, to_batch(back, max_gap_frames=GAP, min_len=N),
                            progress=False, segment_rows=segment_rows)
    assert list(again["verdict"]) == list(verdicts["verdict"]) == ["pedestrian"]
    for k in ("pace_hz", "stride_m"):
        assert float(again[k][0]) == pytest.approx(float(verdicts[k][0]), abs=1e-5), k


def test_rhythm_drops_a_tracks_files_pace_window(tmp_path, capsys, monkeypatch):
    """A tracks file given as BOXES that carries `intensity_wide` (rule 34): `rhythm` samples its
    own windows (the file's candidate columns are dropped) and judges them without a pace
    window: the batch it classifies has the two across columns last and no pace window, and
    the verdicts equal those of the same file without the column; by default (across off
    behind boxes) the file's across columns are not counted either."""
    import cv2

    import rhythmjax.cli.rhythm as rhythm_verb
    from rhythmjax.cli.common import TRACK_ORDER
    from rhythmjax.cli.main import main as cli_main
    from rhythmjax.sim import scene as synth
    from rhythmjax.track import track_frames
    from rhythmjax.track.columns import candidate_columns

    act = synth.walker(-3.4, 12.0, 0.0, pace_hz=1.9, step_length_m=0.62)
    sc = synth.render_scene(3, synth.SceneSpec(n_frames=110, actors=(act,), camera=CFG.camera))
    video = tmp_path / "frames"
    video.mkdir()
    for i, f in enumerate(sc.frames):
        cv2.imwrite(str(video / f"{i:03d}.png"), f)
    tracks, _, _, _ = track_frames(CFG, ((i, i / sc.fps, f) for i, f in enumerate(sc.frames)),
                                   progress=False)
    order = TRACK_ORDER + candidate_columns(tracks)
    plain, wide = tmp_path / "plain.csv", tmp_path / "wide.csv"
    write_table(str(plain), tracks, order)
    write_table(str(wide), {**tracks, PACE_COLUMN: tracks["intensity"]}, order + [PACE_COLUMN])
    assert read_tracks(str(wide)).pace_window
    batches, inner = [], rhythm_verb.classify_tracks
    monkeypatch.setattr(rhythm_verb, "classify_tracks",
                        lambda cfg, batch, **kw: batches.append(batch) or inner(cfg, batch, **kw))
    got = []
    for boxes in (plain, wide):
        out = tmp_path / boxes.stem
        assert cli_main(["rhythm", str(video), "--boxes", str(boxes), "-o", str(out), "--json",
                         "--no-camera-check", "--fps", "15", "--across-candidates"]) == 0
        capsys.readouterr()
        got.append((out / "verdicts.csv").read_text())
    assert got[0] == got[1] and "pedestrian" in got[1]
    for b in batches:
        assert (b.pace_window, b.across, b.candidates.shape[-1]) == (False, 2, 5)
    # the file's across columns are dropped with the rest: by default `rhythm` samples none
    batches.clear()
    assert cli_main(["rhythm", str(video), "--boxes", str(wide), "-o", str(tmp_path / "d"),
                     "--json", "--no-camera-check", "--fps", "15"]) == 0
    capsys.readouterr()
    assert [(b.pace_window, b.across, b.candidates.shape[-1]) for b in batches] == [(False, 0, 3)]
