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

from .. import __version__
from ..io import (
    BadInput,
    Terminated,
    check_output,
    dumps_json,
    raise_on_sigterm,
    table_suffix,
    write_config,
    write_table,
)
from ..io.stream import BLOCK_TRACKS
from ..model.long_tracks import SEGMENT_ROWS
from ..model.params import ConfigError, config_to_dict
from ..sim.bulk import MIX_KINDS, write_bulk_tracks
from ..sim.tracks import make_tracks
from .camera import register as register_camera
from .common import (
    EPILOG,
    Formatter,
    add_common,
    add_height_rules,
    amount_arg,
    count_arg,
    emit_json,
    height_rules,
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
    """Write a synthetic tracks file with known labels (`sim.tracks`; `--bulk`: `sim.bulk`)."""

    table_suffix(args.output)
    check_output(args.output, [args.config])
    cfg = load_config(args.config)
    if args.bulk:  # N tracks in the proportions of the counts, block by block (sim.bulk)
        mix = dict(zip(MIX_KINDS, (args.walkers, args.bicycles, args.dogs, args.cars, args.short)))
        s = write_bulk_tracks(args.output, args.bulk, seed=args.seed, mix=mix, camera=cfg.camera,
                              progress=not (args.quiet or args.json))
        if args.json:
            emit_json(s)
        else:
            say(args, f"wrote {args.output}: {s['n_tracks']} tracks, {s['n_rows']} rows")
        return 0
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

    Streaming (the default): the tracks are read by record batches and classified in blocks of
    whole tracks while the next block is read, each block's verdicts written as a part beside
    the output (`.VERDICTS.parts/`) and the parts joined into VERDICTS at the end, in the
    input's track order. Memory does not grow with the file (about 4 blocks of --block-tracks
    tracks at once). An interrupted run (Ctrl-C, SIGTERM, kill) rerun with the same command
    resumes after the parts done; a changed input or config starts over. A track's rows must
    be contiguous to stream (rows of a track in any frame order); a file where a track's id
    comes back after other tracks is read whole (a note says so). TRACKS may be several files
    or a folder of them (a Parquet dataset); VERDICTS a folder (a path ending in '/') keeps
    the parts there as a Parquet dataset.

    A track longer than --segment-rows (4096) is classified in segments (`model.long_tracks`,
    the same verdicts) and padded apart from the other tracks, so one track's work is bounded
    (one track of 1e5 rows 0.68-0.69 GB, of 1e6 rows 0.98-1.07 GB; docs/benchmarks.md).

    With -o, a report is written beside the verdicts when they are done: VERDICTS' stem +
    .report.html (a folder DIR/: DIR.report.html), the summary, the first 5000 verdict rows and
    the config on one page (--no-report skips it).

    Where the tracks have top rows (columns v_top, top_at_edge: `run`, `track`, `count` and
    `rhythm` write them), a window read at twice a walker's pace is judged at half it where
    the object is as tall as a walker (--twice-pace-heights, rule 37), and a window judged
    Pedestrian whose object is lower than half a walker is refused, too-low
    (--min-height-heights, rule 26), as the tracker judges."""

    from ..stream.classify import classify_source, classify_whole

    inputs = list(args.tracks)
    dataset = bool(args.output) and args.output.endswith(("/", os.sep))
    if args.output and not dataset:
        table_suffix(args.output)
        check_output(args.output, [*inputs, args.config])
    elif dataset:
        _check_dataset_output(args.output, inputs)
    if args.output and not args.no_report:
        from .report import report_path

        check_output(report_path(args.output), [*inputs, args.config])
    if args.whole_file and (len(inputs) > 1 or os.path.isdir(inputs[0]) or dataset):
        raise BadInput(inputs[0], "--whole-file reads one tracks file into one verdicts file")
    source = inputs if len(inputs) > 1 else inputs[0]
    cfg = load_config(args.config)
    size = height_rules(args)
    progress = not (args.quiet or args.json)
    devices = _device_count(args.devices)
    if args.dask:
        from ..stream.distributed import classify_dask

        summary = classify_dask(cfg, source, args.output, scheduler=args.dask,
                                n_workers=args.dask_workers, chunk=args.chunk,
                                segment_rows=args.segment_rows, progress=progress,
                                resume=not args.no_resume, devices=devices,
                                log=lambda msg: say(args, msg), size=size)
    elif args.whole_file:
        summary = classify_whole(cfg, source, args.output, chunk=args.chunk,
                                 segment_rows=args.segment_rows, progress=progress,
                                 devices=devices, size=size)
    else:
        summary = classify_source(cfg, source, args.output, chunk=args.chunk,
                                  segment_rows=args.segment_rows, progress=progress,
                                  resume=not args.no_resume, devices=devices,
                                  block_tracks=args.block_tracks,
                                  log=lambda msg: say(args, msg), size=size)
    verdicts = summary.pop("verdicts_table", None)
    summary = {"input": inputs[0] if len(inputs) == 1 else inputs, "output": args.output,
               **summary}
    if args.output and not args.no_report:
        summary["report"] = _classify_report(args, cfg, summary)
    if args.json:
        emit_json(summary)
    else:
        if not args.output and verdicts is not None:
            print_verdicts(verdicts)
        v = summary["verdicts"]
        say(args, f"{summary['n_tracks']} tracks: {v['pedestrian']} pedestrian, "
             f"{v['non-pedestrian']} non-pedestrian, {v['unclassified']} unclassified"
             + (f"; wrote {args.output}" if args.output else ""))
        for note in summary["notes"]:
            say(args, note if note.startswith("warning") else f"note: {note}")
    return 0


def _classify_report(args, cfg, summary) -> str:
    """Write the report beside the verdicts (`report.report_path`): the summary, the first
    verdict rows and the config; its path."""
    from .report import read_verdicts_head, render_report, report_path, write_report

    path = report_path(args.output)
    link = os.path.relpath(args.output.rstrip("/" + os.sep), os.path.dirname(path) or ".")
    page = render_report(title=f"rhythmjax classify {os.path.basename(str(args.tracks[0]))}",
                         summary=summary, verdicts=read_verdicts_head(args.output),
                         config=config_to_dict(cfg), outputs=[link],
                         n_tracks=int(summary.get("n_tracks", 0)))
    write_report(path, page)
    return path


def _device_count(devices: int | str | None) -> int | None:
    """--devices as a count of the local devices JAX sees ('all': every one)."""
    if devices is None:
        return None
    import jax

    have = len(jax.local_devices())
    if devices == "all":
        return have
    if devices > have:
        raise BadInput("--devices", f"asked for {devices} devices, JAX sees {have} (on a CPU, "
                                    f"add --host-devices {devices})")
    return devices


def _check_dataset_output(out: str, inputs: list[str]) -> None:
    """A folder output: not one of the inputs (nor inside one), its parent a folder."""
    real = os.path.realpath(out)
    for src in inputs:
        s = os.path.realpath(src)
        if real == s or real.startswith(s.rstrip(os.sep) + os.sep) or \
                s.startswith(real.rstrip(os.sep) + os.sep):
            raise BadInput(out, f"is the input '{src}' or holds it; give another output "
                                "folder")
    parent = os.path.dirname(real.rstrip(os.sep)) or "."
    if not os.path.isdir(parent):
        raise BadInput(out, f"output directory '{parent}' does not exist")
    if os.path.exists(real) and not os.path.isdir(real):
        raise BadInput(out, "is a file; give a folder (ending in '/') for a dataset output")


def devices_arg(text: str) -> int | str:
    """--devices: a positive count or 'all'."""
    if text.strip().lower() == "all":
        return "all"
    return count_arg(text)


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
    p.add_argument("--bulk", type=count_arg, metavar="N", help="N tracks (1e4-1e6 and more) in "
                   "the proportions of the counts above, generated vectorised block by block "
                   "(`sim.bulk`; memory does not grow with N)")
    add_common(p)
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser("classify", formatter_class=Formatter, help="batch-classify stored "
                       "tracks", description=cmd_classify.__doc__, epilog=EPILOG)
    p.add_argument("tracks", metavar="TRACKS", nargs="+", help="tracks file (.csv or "
                   ".parquet), several, or a folder of them (a Parquet dataset)")
    p.add_argument("-o", "--output", metavar="VERDICTS", help="verdicts file (.csv or "
                   ".parquet), or a folder ('DIR/', ending in '/') for a Parquet dataset of "
                   "parts; printed as a table when omitted")
    p.add_argument("--chunk", type=count_arg, default=256, help="tracks per jitted chunk")
    p.add_argument("--segment-rows", type=count_arg, default=SEGMENT_ROWS, metavar="L",
                   help="a track longer than L rows is filtered L rows at a time, the filter "
                   "state carried on (same verdicts), so its memory does not grow with its "
                   "length")
    p.add_argument("--block-tracks", type=count_arg, default=BLOCK_TRACKS, metavar="K",
                   help="tracks per block (one part of the output; the resume step): memory "
                   "holds about 4 blocks")
    p.add_argument("--no-resume", action="store_true", help="start over even when an "
                   "interrupted run with the same input and config left parts to resume from")
    p.add_argument("--whole-file", action="store_true", help="read the whole file into "
                   "memory first (the path before streaming; memory grows with the file)")
    p.add_argument("--devices", type=devices_arg, default=None, metavar="N|all",
                   help="local devices to shard each kernel call's tracks over (none given: the "
                   "default device; all: every device JAX sees)")
    p.add_argument("--host-devices", type=count_arg, default=None, metavar="N",
                   help="on a CPU, show JAX N host devices (jax_num_cpu_devices), for --devices")
    p.add_argument("--dask", nargs="?", const="local", default=None, metavar="ADDRESS",
                   help="map the classifier over partitions with Dask: a local cluster, or "
                   "the scheduler at ADDRESS")
    p.add_argument("--dask-workers", type=count_arg, default=2, metavar="W",
                   help="workers of the local Dask cluster")
    p.add_argument("--no-report", action="store_true", help="skip the report beside the "
                   "verdicts (VERDICTS' stem + .report.html: summary, verdict table, config)")
    add_height_rules(p)
    add_common(p)
    p.set_defaults(func=cmd_classify)

    register_video(sub, Formatter)
    register_count(sub, Formatter)
    register_camera(sub, Formatter)
    register_rhythm(sub, Formatter)
    return parser


def _host_devices(n: int, argv) -> bool:
    """Show JAX `n` CPU devices (jax_num_cpu_devices; the CLI's choice, never the library's).
    Importing rhythmjax starts JAX's backend, so from a shell (`argv` None) the command starts
    again with JAX_NUM_CPU_DEVICES set, which JAX reads when it starts; in process it is set
    only if the backend has not started. False when it cannot be set."""
    if os.environ.get("JAX_NUM_CPU_DEVICES") == str(n):
        return True
    if argv is None:
        env = {**os.environ, "JAX_NUM_CPU_DEVICES": str(n)}
        os.execve(sys.executable, [sys.executable, "-c", "import sys; from rhythmjax.cli.main "
                                   "import main; sys.exit(main())", *sys.argv[1:]], env)
    import jax

    try:
        jax.config.update("jax_num_cpu_devices", n)
    except RuntimeError:
        return len(jax.devices("cpu")) == n
    return True


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
    if getattr(args, "host_devices", None) and not _host_devices(args.host_devices, argv):
        print(f"rhythmjax {args.command}: error: --host-devices must reach JAX before it "
              f"starts: run rhythmjax from a shell, or set JAX_NUM_CPU_DEVICES="
              f"{args.host_devices}", file=sys.stderr)
        return 2
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
