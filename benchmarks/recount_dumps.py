"""Recount a counting run saved by `benchmarks/count_dump.py` under another counting rule, the
tracks unchanged: the rules below decide only which judged tracks are counted, so applying them
to a saved run gives exactly what the tracker would count with them (issue 16, twenty-third
round; docs/rules.md). Writes a dump of the same form (atomically) for `paired_dumps.py`.

Rules (`--rule`):
- `no-peak`: a track judged Non-pedestrian only because no window's spectral peak reached P_thr
  (reason "no-peak": no rhythm seen, rather than one outside the walking model) is counted as an
  unjudged track is: unless too fast (`too_fast`, 2.57 m/s).
- `speed-se:Z`: an unjudged track is too fast only when its least-squares ground speed less Z
  standard errors still exceeds the top walking speed (`speed_and_se`; the count's speed is the
  same fit, `count.track_speed` "lsq").
- `speed-fit:FIT`: the unjudged tracks' too-fast test from `count.points_speed` with `FIT`
  ("lsq" or "theil-sen") on the same rows (observed, ground estimate finite): exactly what
  `verdicts.speed_fit` FIT gives the count, the tracks unchanged (issue 16, rule 25).
- `head-speed`: the too-fast test reads the speed under the heads where a track's foot rows
  are mostly not its feet (`verdicts.head_speed`, rule 31: `count.head_feet.head_ground_points`
  with the camera of `--camera`: `count:FOCAL_PX` for the own scenes, `dev`, `pets`).

    python benchmarks/recount_dumps.py RUN.pkl OUT.pkl --rule no-peak
    python benchmarks/recount_dumps.py RUN.pkl OUT.pkl --rule speed-fit:theil-sen
    python benchmarks/recount_dumps.py RUN.pkl OUT.pkl --rule head-speed --camera count:500
    python benchmarks/paired_dumps.py RUN.pkl OUT.pkl

Nothing is chosen here: it recounts.
"""

from __future__ import annotations

import argparse
import os
import pickle
import tempfile

import numpy as np


def top_speed() -> float:
    """The top walking speed m/s of Table 1's walking model (`count.walking_top_speed`: 2.57)."""
    from rhythmjax.count import walking_top_speed
    from rhythmjax.model.params import config_from_dict

    return walking_top_speed(config_from_dict({}))


def speed_and_se(t, x, y) -> tuple[float, float]:
    """Ground speed (m/s) of the least-squares slopes of x and y (m) against t (s), and its
    standard error by the delta method from the slopes' residual variances (each slope's
    variance s^2 / sum (t - mean t)^2, s^2 the residuals' squares over n - 2); NaN with fewer
    than 3 points or a span under 0.5 s (as `count.track_speed`)."""
    t, x, y = (np.asarray(q, np.float64) for q in (t, x, y))
    if t.size < 3 or np.ptp(t) < 0.5:
        return np.nan, np.nan
    tc = t - t.mean()
    stt = float(tc @ tc)
    bx, by = tc @ (x - x.mean()) / stt, tc @ (y - y.mean()) / stt
    rx, ry = x - x.mean() - bx * tc, y - y.mean() - by * tc
    vx, vy = rx @ rx / (t.size - 2) / stt, ry @ ry / (t.size - 2) / stt
    s = float(np.hypot(bx, by))
    se = float(np.sqrt(bx * bx * vx + by * by * vy)) / s if s > 0 else np.nan
    return s, se


def observed_rows(tracks: dict):
    """(track ids, observed mask, t, x_est, y_est) of a saved run's tracks table, the rows a
    track's speed is fitted on (`count.track_speed`: its OBSERVE rows)."""
    t, x, y = (np.asarray(tracks[c], np.float64) for c in ("t", "x_est", "y_est"))
    return np.asarray(tracks["track_id"]), np.asarray(tracks["state"]) == "observe", t, x, y


def config_of(camera: str):
    """The Config `count_dump.py` ran a source with: `count:FOCAL_PX` (the own scenes' preset
    with a f = b f = FOCAL_PX; 0: the preset's), `dev` (the dev clips' camera), `pets`."""
    import json
    import sys

    from rhythmjax.model.params import config_from_dict

    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    if camera == "pets":
        import eval_real_video as ev

        return config_from_dict(ev.pets_config_dict())
    if camera == "dev":
        import eval_all as ea

        clips = json.loads((ea.DEV_ROOT / "index.json").read_text())["clips"]
        clip = next(c for c in clips if c.get("count"))  # every dev clip has the same camera
        return config_from_dict(ea.dev_camera(json.loads((ea.DEV_ROOT / clip["truth"])
                                                         .read_text())))
    if not camera.startswith("count:"):
        raise SystemExit(f"unknown camera {camera!r}: count:FOCAL_PX, dev or pets")
    from count_dump import own_config

    return own_config(float(camera.split(":", 1)[1]))


def track_rows(tracks: dict, tid: int) -> list:
    """The `TrackRow`s of track `tid` of a saved tracks table (state names as ints)."""
    from rhythmjax.model.status import TrackState
    from rhythmjax.track.rows import TrackRow

    k = np.flatnonzero(np.asarray(tracks["track_id"]) == tid)
    state = [int(TrackState[str(s).upper()]) for s in np.asarray(tracks["state"])[k]]
    cols = [np.asarray(tracks[c], np.float64)[k] for c in ("t", "u", "v", "v_top")]
    return [TrackRow(frame=0, t=t, u=u, v=v, width_px=np.nan, intensity=np.nan, x_est=np.nan,
                     y_est=np.nan, state=s, v_top=vt) for s, t, u, v, vt in zip(state, *cols)]


def recounted(record: dict, rule: str, cfg=None) -> np.ndarray:
    """The `counted` column of one clip's record under `rule` (module doc; `cfg`: the run's
    Config, for `head-speed`)."""
    v = record["verdicts"]
    counted = np.asarray(v["counted"], bool).copy()
    verdict, reason = np.asarray(v["verdict"]), np.asarray(v["reason"])
    too_fast = np.asarray(v["too_fast"], bool)
    if rule == "no-peak":
        return counted | ((verdict == "non-pedestrian") & (reason == "no-peak") & ~too_fast)
    if rule.startswith("speed-se:"):
        z = float(rule.split(":", 1)[1])
        ids, observed, t, x, y = observed_rows(record["tracks"])
        top = top_speed()
        for i, tid in enumerate(np.asarray(v["track_id"])):
            if verdict[i] != "unclassified" or not too_fast[i]:
                continue
            k = (ids == tid) & observed & np.isfinite(x) & np.isfinite(y)
            s, se = speed_and_se(t[k], x[k], y[k])
            counted[i] = counted[i] or bool(s - z * se <= top)
        return counted
    if rule.startswith("speed-fit:"):
        from rhythmjax.count import points_speed

        fit, top = rule.split(":", 1)[1], top_speed()
        ids, observed, t, x, y = observed_rows(record["tracks"])
        explained = np.asarray(v.get("explained_by", np.zeros(len(verdict), np.int64))) != 0
        for i, tid in enumerate(np.asarray(v["track_id"])):
            if verdict[i] != "unclassified" or explained[i]:
                continue
            k = (ids == tid) & observed
            counted[i] = not points_speed(t[k], x[k], y[k], fit) > top
        return counted
    if rule == "head-speed":
        from rhythmjax.count.counting import faster_than, head_speed
        from rhythmjax.count.patches import ShapeModel

        shape, n_rows = ShapeModel.from_config(cfg, "3d"), int(record["image_size"][1])
        head = np.asarray([head_speed(shape, track_rows(record["tracks"], tid), n_rows)
                           for tid in np.asarray(v["track_id"])], np.float64)
        too_fast = faster_than(v["track_speed_mps"], head, top_speed())
        explained = np.asarray(v.get("explained_by", np.zeros(len(verdict), np.int64))) != 0
        unjudged = (verdict == "unclassified") & ~explained
        counted[unjudged] = ~too_fast[unjudged]
        return counted
    raise SystemExit(f"unknown rule {rule!r}: no-peak, speed-se:Z, speed-fit:FIT or head-speed")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run")
    ap.add_argument("out")
    ap.add_argument("--rule", required=True)
    ap.add_argument("--camera", default="count:0",
                    help="head-speed: the run's camera (count:FOCAL_PX, dev, pets)")
    a = ap.parse_args(argv)
    cfg = config_of(a.camera) if a.rule == "head-speed" else None
    with open(a.run, "rb") as f:
        records = pickle.load(f)
    before = after = 0
    for r in records:
        c = recounted(r, a.rule, cfg)
        before += int(np.sum(r["verdicts"]["counted"]))
        after += int(c.sum())
        r["verdicts"] = {**r["verdicts"], "counted": c}
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(a.out)), suffix=".tmp")
    with os.fdopen(fd, "wb") as f:
        pickle.dump(records, f)
    os.replace(tmp, a.out)
    print(f"{a.run}: {len(records)} clips, counted {before} -> {after} ({a.rule})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
