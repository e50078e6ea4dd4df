"""Files at the edges: tracks, footprints, verdicts and configs (`files`), tables in CSV and
Parquet (`tables`), atomic writes (`atomic`), MOTChallenge text (`mot`) and the one-line input
error (`errors`). Imports `model` only (for the config)."""

from .atomic import (
    OutputSet as OutputSet,
    Terminated as Terminated,
    check_output as check_output,
    raise_on_sigterm as raise_on_sigterm,
)
from .errors import BadInput as BadInput, PathLike as PathLike
from .files import (
    LABELS as LABELS,
    TRACK_COLUMNS as TRACK_COLUMNS,
    Table as Table,
    TrackBatch as TrackBatch,
    Tracks as Tracks,
    atomic_path as atomic_path,
    atomic_write as atomic_write,
    check_writable as check_writable,
    config_or_bad_input as config_or_bad_input,
    dumps_json as dumps_json,
    make_output_dir as make_output_dir,
    read_config as read_config,
    read_config_dict as read_config_dict,
    read_footprints as read_footprints,
    read_table as read_table,
    read_tracks as read_tracks,
    to_batch as to_batch,
    write_config as write_config,
    write_table as write_table,
)
from .tables import table_suffix as table_suffix
