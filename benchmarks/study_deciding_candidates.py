"""Which candidate window decided each Pedestrian track, and what window B read there, by the
object the track followed (issue 16, fifty-second round; a study: nothing is chosen here).

For every track judged Pedestrian on the own scenes, this re-judges its deciding window per
candidate (`fp_replay.judge`, the tracker's judgement) and prints the candidate that decided
(0: window B; 1-3 the vertical candidates; 4-5 the windows moved across), the reason
(matched-twice: rule 37), the pace F, window B's strongest peak f1 with its power and f1 / F,
and whether the window's rows are as tall as a walker by rule 37's test
(`track.twice.rows_tall_enough`), with the kind of the object the track follows
(`sim.evaluate.match_tracks`). Tracked as `eval_synthetic.py` tracks (cached under -d; the
caches of `study_twice_heights.py` and `study_tail_speed.py` are the same).

    python benchmarks/study_deciding_candidates.py SEED[,SEED...] [--lateral] [--scenes 10] -d DIR
"""

from __future__ import annotations

import sys
from pathlib import Path


sys.path.insert(0, str(Path(__file__).parent))

from eval_synthetic import RECOMMENDED  # noqa: E402
from fp_replay import judge  # noqa: E402
from study_tracks import scenes_of, study_parser  # noqa: E402


def main(argv=None) -> int:
    from rhythmjax.model.camera_np import camera_tuple
    from rhythmjax.model.params import config_from_dict, host_float
    from rhythmjax.model.status import Reason, Verdict
    from rhythmjax.sim.evaluate import match_tracks
    from rhythmjax.sim.presets import synthetic_options
    from rhythmjax.track.twice import rows_tall_enough

    a = study_parser(__doc__).parse_args(argv)
    cfg = config_from_dict(RECOMMENDED)
    size = synthetic_options().size
    camera, walker_m = camera_tuple(cfg.camera), host_float(cfg.width.height)
    for name, tracks, objs, truth in scenes_of(cfg, a):
        owner = match_tracks(tracks, truth)
        for o in objs:
            r = o.result
            if r is None or "window" not in r or int(r["verdict"]) != Verdict.PEDESTRIAN:
                continue
            k0, k1 = (int(k) for k in r["window"])
            b = judge(cfg, o, k0)[2][0]  # window B's own outcome
            f1 = float(b["peak_freq"][0]) if bool(b["peak_mask"][0]) else float("nan")
            pace = float(r["pace_hz"])
            tall = rows_tall_enough(o.rows[k0:k1], camera, walker_m, size)
            kind = getattr(owner.get(o.track_id), "kind", "none")
            print(f"{name} track {o.track_id} ({kind}) candidate "
                  f"{int(r.get('candidate', 0))} {Reason(int(r['reason'])).name} "
                  f"F {pace:.2f} Hz; window B f1 {f1:.2f} Hz power "
                  f"{float(b['peak_power'][0]):.1f}, f1/F {f1 / pace:.2f}; tall {tall}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
