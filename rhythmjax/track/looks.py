"""The tracker's height rules as one `second_look`: for the batch classifier, rules 37 and 26 on
each window of `model.batch.classify_tracks` (`height_looks`), used by `rhythm --boxes`,
`classify` and count's verdicts; for the online tracker, rule 37 and, with rule 45
(`size.every_window`), rule 26 on each window as it completes (`tracker_look`). With rule 45
every classifier of the project judges a window the same way."""

from __future__ import annotations

from ..model.params import Config, host_float
from .options import SizeOptions
from .size import batch_size_look, refuse_low
from .twice import batch_second_look, second_look


__all__ = ["height_looks", "reads_heights", "tracker_look"]


def reads_heights(size: SizeOptions | None) -> bool:
    """Whether the verdicts read the tracks' top rows: rule 37 or rule 26 on in `size`."""
    return size is not None and (size.twice_pace_heights > 0 or size.min_height_heights > 0)


def height_looks(cfg: Config, batch, size: SizeOptions | None):
    """`classify_tracks`' `second_look` of rules 37 and 26 (`size`; None: neither) for `batch`
    (a `TrackBatch`; its top rows `v_top`, `top_at_edge`): rule 37 on each window
    (`twice.batch_second_look`), then rule 26 on each window judged Pedestrian
    (`size.batch_size_look`). None when both are off or the batch has no top rows."""
    if not reads_heights(size):
        return None
    return batch_size_look(cfg, batch, size, then=batch_second_look(cfg, batch, size))


def tracker_look(cfg: Config, camera, size: SizeOptions):
    """A tracked object's `second_look` (`toolkit.match_window` calls it with a window's outcome
    and its N rows): rule 37 (`twice.second_look`), then, with rule 45 (`size.every_window`) and
    rule 26 on, `size.refuse_low` on the window's own rows, so a window judged Pedestrian but
    lower than `min_height_heights` walker heights is refused (too-low) and matching goes on.
    `twice` False (rule 50b's windows moved across): rule 26 only. None when neither applies."""
    first = second_look(cfg, camera, size)
    if not size.every_window or size.min_height_heights <= 0:
        return first
    walker_m = host_float(cfg.width.height)

    def look(out: dict, rows: list, twice: bool = True) -> dict:
        out = out if first is None else first(out, rows, twice=twice)
        return refuse_low(out, camera, list(rows), walker_m, size)

    return look
