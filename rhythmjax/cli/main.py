"""`rhythmjax` command line: config, simulate, classify here; demo, track, run (`cli.video`) and
count (`cli.count`) registered explicitly.

Exit codes: 0 success, 2 bad input (one line naming the file and the row, column, key or track),
1 internal or I/O failure, 130 interrupted (Ctrl-C), 143 terminated (SIGTERM); an interrupted
run leaves the previous outputs whole and no temp file. `--debug` shows tracebacks.
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

from .. import __version__
from ..io import (
    BadInput,
    Terminated,
    check_output,
    dumps_json,
    raise_on_sigterm,
    read_tracks,
    table_suffix,
    to_batch,
    write_config,
    write_table,
)
from ..model.batch import VERDICT_COLUMNS, classify_tracks, merge_verdicts, summarise
from ..model.long_tracks import SEGMENT_ROWS
from ..model.params import ConfigError, config_to_dict
from ..sim.tracks import make_tracks
from .camera import register as register_camera
from .common import (
    EPILOG,
    Formatter,
    add_common,
    amount_arg,
    count_arg,
    emit_json,
    load_config,
    print_verdicts,
    say,
    seed_arg,
)
from .count import register as register_count
from .rhythm import register as register_rhythm
from .video import register as register_video


# ----------------------------------------------------------------------------------------------
def cmd_config(args) -> int:
    """Print the full config (defaults, or the given file merged over them)."""

    if args.output:
        check_output(args.output, [args.config])
    cfg = load_config(args.config)
    if args.output:
        write_config(args.output, cfg)
        say(args, f"wrote {args.output}")
    else:
        print(dumps_json(config_to_dict(cfg), indent=2))
    return 0


def cmd_simulate(args) -> int:
    """Write a synthetic tracks file with known labels (see `rhythmjax.simtracks`)."""

    table_suffix(args.output)
    check_output(args.output, [args.config])
    cfg = load_config(args.config)
    cols, truth = make_tracks(n_walkers=args.walkers, n_bicycles=args.bicycles,
                              n_dogs=args.dogs, n_cars=args.cars, n_short=args.short,
                              seed=args.seed, camera=cfg.camera)
    order = ["track_id", "frame", "t", "u", "v", "width_px", "intensity", "label", "x", "y"]
    write_table(args.output, cols, order)
    summary = {"output": args.output, "n_tracks": len(truth), "n_rows": int(len(cols["frame"])),
               "labels": {k: sum(t.label == k for t in truth) for k in sorted({t.label for t in
                                                                                truth})}}
    if args.json:
        emit_json(summary)
    else:
        say(args, f"wrote {args.output}: {summary['n_tracks']} tracks, {summary['n_rows']} rows")
    return 0


def cmd_classify(args) -> int:
    """Batch-classify stored tracks: EKF with the paper's gates, MEM spectrum, (13)-(15).

    Memory: a track longer than --segment-rows (4096) is classified in segments
    (`model.long_tracks`, the same verdicts) and padded apart from the other tracks, so one
    track's work is bounded: peak RSS about 0.65 GB plus about 0.4 KB per row of the file (one
    track of 1e5 rows 0.68-0.69 GB, of 1e6 rows 0.98-1.07 GB; docs/benchmarks.md), where
    one track of 1e5 rows took 3.2 GB before."""

    if args.output:
        table_suffix(args.output)
        check_output(args.output, [args.tracks, args.config])
    cfg = load_config(args.config)
    tracks = read_tracks(args.tracks, fps=cfg.camera.fps)
    blind = blind_camera_note(cfg, tracks)
    if blind:
        tracks.notes.append(blind)
    n = cfg.thresholds.n
    gap = max(1, round(float(cfg.thresholds.predict_timeout) * cfg.camera.fps))
    parts = []
    for group in tracks.by_span(args.segment_rows):  # a long track pads no other
        batch = to_batch(group, max_gap_frames=gap, min_len=n)
        part = classify_tracks(cfg, batch, chunk=args.chunk, segment_rows=args.segment_rows,
                               progress=not (args.quiet or args.json))
        if batch.labels is not None:
            part["label"] = np.asarray(batch.labels, dtype=object)
        parts.append(part)
    verdicts = merge_verdicts(parts, tracks.ids)
    labels = verdicts.get("label")
    order = list(VERDICT_COLUMNS)
    if labels is not None:
        order.append("label")
    if args.output:
        write_table(args.output, verdicts, order)
    summary = {"input": args.tracks, "output": args.output, **summarise(verdicts, labels),
               "notes": list(tracks.notes)}
    if args.json:
        emit_json(summary)
    else:
        if not args.output:
            print_verdicts(verdicts)
        v = summary["verdicts"]
        say(args, f"{summary['n_tracks']} tracks: {v['pedestrian']} pedestrian, "
             f"{v['non-pedestrian']} non-pedestrian, {v['unclassified']} unclassified"
             + (f"; wrote {args.output}" if args.output else ""))
        for note in tracks.notes:
            say(args, note if note.startswith("warning") else f"note: {note}")
    return 0


def blind_camera_note(cfg, tracks) -> str | None:
    """A warning when the config's camera sees none of the tracks' foot points (u, v) on the
    ground inside the detection range: every track would be cut by the gates and left
    unclassified (as `run` checks the camera against the video)."""
    from ..model.camera_np import ground_of_pixels

    have = np.isfinite(tracks.u) & np.isfinite(tracks.v)
    if not have.any():
        return None
    _, y, ok = ground_of_pixels(cfg.camera, tracks.u[have], tracks.v[have])
    thr = cfg.thresholds
    lo, hi = float(thr.range_min), float(thr.range_max)
    if np.any(ok & (y >= lo) & (y <= hi)):
        return None
    return (f"warning: the config's camera sees none of the {int(have.sum())} foot points on "
            f"the ground within the detection range {lo:g}-{hi:g} m ({int(np.sum(ok))} below "
            "the horizon at all): every track will be unclassified; check camera.h_m, "
            "theta_deg, vc_px (`rhythmjax camera`)")


# ----------------------------------------------------------------------------------------------
def build_parser() -> argparse.ArgumentParser:

    parser = argparse.ArgumentParser(
        prog="rhythmjax", formatter_class=Formatter, epilog=EPILOG,
        description="Tell walking people apart from other moving objects in fixed-camera video "
                    "by the rhythm of their gait (Yasutomi & Mori), with a JAX EKF and MEM.")
    parser.add_argument("--version", action="version", version=f"rhythmjax {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    p = sub.add_parser("config", formatter_class=Formatter, help="print the full default "
                       "config, or merge a config over the defaults",
                       description=cmd_config.__doc__)
    p.add_argument("-o", "--output", metavar="C2", help="write the merged config here instead")
    add_common(p)
    p.set_defaults(func=cmd_config)

    p = sub.add_parser("simulate", formatter_class=Formatter, help="write a synthetic "
                       "labelled tracks file", description=cmd_simulate.__doc__)
    p.add_argument("-o", "--output", required=True, metavar="TRACKS",
                   help="output tracks file (.csv or .parquet)")
    p.add_argument("--seed", type=seed_arg, default=0)
    p.add_argument("--walkers", type=amount_arg, default=20)
    p.add_argument("--bicycles", type=amount_arg, default=5)
    p.add_argument("--dogs", type=amount_arg, default=5)
    p.add_argument("--cars", type=amount_arg, default=3)
    p.add_argument("--short", type=amount_arg, default=2, help="walkers tracked < N frames")
    add_common(p)
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser("classify", formatter_class=Formatter, help="batch-classify stored "
                       "tracks", description=cmd_classify.__doc__, epilog=EPILOG)
    p.add_argument("tracks", metavar="TRACKS", help="tracks file (.csv or .parquet)")
    p.add_argument("-o", "--output", metavar="VERDICTS", help="verdicts file (.csv or "
                   ".parquet); printed as a table when omitted")
    p.add_argument("--chunk", type=count_arg, default=256, help="tracks per jitted chunk")
    p.add_argument("--segment-rows", type=count_arg, default=SEGMENT_ROWS, metavar="L",
                   help="a track longer than L rows is filtered L rows at a time, the filter "
                   "state carried on (same verdicts), so its memory does not grow with its "
                   "length")
    add_common(p)
    p.set_defaults(func=cmd_classify)

    register_video(sub, Formatter)
    register_count(sub, Formatter)
    register_camera(sub, Formatter)
    register_rhythm(sub, Formatter)
    return parser


def _enable_compilation_cache() -> None:
    """Keep compiled XLA programs between runs (the application's choice, never the library's):
    a second `rhythmjax classify` skips the ~10 s compilation. RHYTHMJAX_CACHE_DIR=0 disables."""
    d = os.environ.get("RHYTHMJAX_CACHE_DIR",
                       os.path.join(os.path.expanduser("~"), ".cache", "rhythmjax", "xla"))
    if d and d != "0":
        import jax

        jax.config.update("jax_compilation_cache_dir", d)
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)


def main(argv=None) -> int:

    parser = build_parser()
    args = parser.parse_args(argv)
    _enable_compilation_cache()
    raise_on_sigterm()  # SIGTERM cleans up as Ctrl-C does: no temp file, the old outputs whole
    try:
        return args.func(args)
    except (BadInput, ConfigError) as e:
        if args.debug:
            raise
        print(f"rhythmjax {args.command}: error: {e}", file=sys.stderr)
        return 2
    except Terminated:
        print(f"rhythmjax {args.command}: terminated (SIGTERM); no output replaced",
              file=sys.stderr)
        return 143
    except KeyboardInterrupt:
        print(f"rhythmjax {args.command}: interrupted; no output replaced", file=sys.stderr)
        return 130
    except BrokenPipeError:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 1
    except Exception as e:  # noqa: BLE001 - one line, not a traceback, unless --debug
        if args.debug:
            raise
        print(f"rhythmjax {args.command}: internal error: {type(e).__name__}: {e} "
              "(rerun with --debug for the traceback)", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
