"""Verdicts written part by part while a streaming run goes on, resumable, then assembled.

Each part (the verdicts of one block of whole tracks, in file order) is a Parquet file written
atomically (`atomic_path`: a temp file beside it, fsync, rename) into a hidden folder beside the
output, `.<output name>.parts/`, and the manifest there (`_rhythmjax_manifest.json`, also written
atomically after each part) lists the parts done and the run's key: the inputs' fingerprint
(absolute paths, sizes, modification times), a hash of the config and the settings that fix the
blocks (chunk, segment rows, block size) and the package version. A rerun with the same key
resumes after the last part listed; any other key starts over. At the end the parts are copied
one at a time, in order, into the output (one temp file renamed over it: atomic, never all in
memory) and the folder removed.

Dataset output (`dataset=True`, an output folder): the parts are the result, `part-000000.parquet`
... in track order in that folder, read back as one table by `pyarrow.dataset` (which, like
pandas, skips the manifest, whose name starts with '_'); the manifest stays, marked complete,
so a rerun with the same key does nothing. While a run goes on the folder holds the parts done so
far (not atomic as a whole).
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil

from .atomic import atomic_path, atomic_write, signals_deferred
from .errors import BadInput, PathLike
from .table_write import arrow_table
from .tables import table_suffix


MANIFEST = "_rhythmjax_manifest.json"
FORMAT = 1


def parts_folder(output: PathLike) -> str:
    """The hidden folder beside `output` that holds its parts while a run goes on."""
    d, name = os.path.split(os.path.abspath(os.fspath(output)))
    return os.path.join(d, f".{name}.parts")


class VerdictParts:
    """The parts of one output. `open` reads what an earlier run left; `write` adds a part;
    `assemble` (file output) or `finish` (dataset output) ends the run; `discard` removes it."""

    def __init__(self, output: PathLike, key: dict, *, dataset: bool = False):
        self.output = os.fspath(output)
        self.key = json.loads(json.dumps(key))  # as it reads back from the manifest
        self.dataset = dataset
        self.folder = os.path.abspath(self.output) if dataset else parts_folder(self.output)
        self.done: list[dict] = []
        self.resumed = 0
        self._made = False

    @property
    def manifest(self) -> str:
        return os.path.join(self.folder, MANIFEST)

    def part_path(self, entry: dict) -> str:
        return os.path.join(self.folder, entry["file"])

    # -- start -----------------------------------------------------------------------------
    def open(self, *, resume: bool = True) -> str | None:
        """Take up an earlier run's parts when its key is this run's (and `resume`), else remove
        them. Returns a line to tell the user (resuming, starting over), or None."""
        old = self._load()
        if old is None:
            return None
        if resume and old.get("key") == self.key:
            for e in old.get("parts", []):
                if not os.path.isfile(self.part_path(e)):
                    break
                self.done.append(e)
            self.resumed = len(self.done)
            self._clean(keep={e["file"] for e in self.done} | {MANIFEST})
            if old.get("complete") and self.dataset:
                return None
            n = sum(int(e.get("tracks", 0)) for e in self.done)
            return (f"resuming the interrupted run from {self.folder}: {self.resumed} part(s), "
                    f"{n} tracks, already done (not redone)")
        why = ("--no-resume" if not resume else "the input or the config changed" if old
               else "no readable manifest")
        self._clean(keep=set())
        return f"{why}: the parts of an earlier run in {self.folder} removed; starting over"

    def _load(self) -> dict | None:
        if not os.path.isdir(self.folder):
            if os.path.exists(self.folder) and self.dataset:
                raise BadInput(self.output, "is not a folder; give a folder for a dataset "
                                            "output")
            return None
        try:
            with open(self.manifest, encoding="utf-8") as f:
                m = json.load(f)
            if not isinstance(m, dict) or m.get("format") != FORMAT:
                raise ValueError
            return m
        except (OSError, ValueError):
            if self.dataset and self._foreign():
                raise BadInput(self.output, "the folder holds other files; give an empty or "
                                            "new folder for a dataset output") from None
            ours = any(n.startswith(("part-", ".part-")) or n == MANIFEST
                       for n in os.listdir(self.folder))
            return {} if ours else None

    def _foreign(self) -> bool:
        return any(not (n.startswith("part-") or n.startswith(".") or n == MANIFEST)
                   for n in os.listdir(self.folder))

    def _clean(self, keep: set[str]) -> None:
        """Remove what a run left here but `keep`: temp files, parts not listed."""
        for n in os.listdir(self.folder):
            ours = n.startswith(("part-", ".part-", f".{os.path.splitext(MANIFEST)[0]}")) \
                or n == MANIFEST
            if ours and n not in keep:
                with contextlib.suppress(OSError):
                    os.unlink(os.path.join(self.folder, n))

    # -- parts -----------------------------------------------------------------------------
    def write(self, columns: dict, order: list[str], meta: dict) -> dict:
        """Write the next part (`columns` in `order`) atomically, then the manifest; `meta`
        (JSON: tracks, notes, ...) is kept with it. Returns its manifest entry."""
        import pyarrow.parquet as pq

        if not os.path.isdir(self.folder):
            os.makedirs(self.folder)
            self._made = True
        entry = {"file": f"part-{len(self.done):06d}.parquet", "columns": list(order), **meta}
        with signals_deferred():  # a part is renamed in only with the manifest that names it
            with atomic_path(self.part_path(entry)) as tmp:
                pq.write_table(arrow_table(columns, order), tmp)
            self.done.append(entry)
            self._save()
        return entry

    def _save(self, complete: bool = False) -> None:
        m = {"format": FORMAT, "key": self.key, "parts": self.done, "complete": complete}
        with atomic_write(self.manifest, "w") as f:
            json.dump(m, f, indent=1)

    # -- end -------------------------------------------------------------------------------
    def assemble(self) -> None:
        """Copy the parts in order into the output file (CSV or Parquet by its suffix), one part
        in memory at a time, through a temp file renamed over the output; then remove the
        folder."""
        import pyarrow.csv as pacsv
        import pyarrow.parquet as pq

        csv = table_suffix(self.output) == ".csv"
        with atomic_path(self.output) as tmp:
            writer, schema = None, None
            try:
                for e in self.done:
                    t = pq.read_table(self.part_path(e))
                    if writer is None:
                        schema = t.schema
                        writer = (pacsv.CSVWriter(tmp, schema, write_options=pacsv.WriteOptions(
                            quoting_style="needed")) if csv else pq.ParquetWriter(tmp, schema))
                    elif t.schema != schema:
                        t = t.cast(schema)
                    writer.write_table(t)
            finally:
                if writer is not None:
                    writer.close()
        self.discard()

    def finish(self) -> None:
        """Dataset output: mark the manifest complete (the parts stay as the result)."""
        self._save(complete=True)

    def discard(self) -> None:
        """Remove the parts folder (dataset output: the parts and manifest this run wrote, and
        the folder if it made it)."""
        if not os.path.isdir(self.folder):
            return
        if self.dataset:
            self._clean(keep=set())
            if self._made:
                with contextlib.suppress(OSError):
                    os.rmdir(self.folder)
        else:
            shutil.rmtree(self.folder, ignore_errors=True)

    def discard_if_empty(self) -> None:
        """After an interruption: remove the folder when no part was written (nothing to resume
        from)."""
        if not self.done:
            self.discard()
