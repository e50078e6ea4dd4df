"""The tracker's height rules for the batch classifier: rules 37 and 26 as one `second_look` of
`model.batch.classify_tracks` (`height_looks`), used by `rhythm --boxes`, `classify` and count's
verdicts, so that every classifier of the project judges a window as the tracker does."""

from __future__ import annotations

from ..model.params import Config
from .options import SizeOptions
from .size import batch_size_look
from .twice import batch_second_look


__all__ = ["height_looks", "reads_heights"]


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
