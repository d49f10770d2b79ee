"""Where a campaign's rows live: a JSON-lines journal written as missions finish, and the tables made from it.

``DIR/missions.jsonl`` gets one line per finished mission, flushed and synced
before the next is taken, so a crash or Ctrl-C loses at most the missions in
flight. A rerun into the same folder reads it back and skips every mission
whose row is there with the same spec digest (a failed one too, unless asked
to retry; a mission the cluster lost — its worker died — is always rerun).
A torn last line (the process died mid-write) is ignored. At the end
the journal is consolidated into ``DIR/missions.parquet`` and ``DIR/missions.csv``
(the newest row per mission id, in the grid's order).
"""
from __future__ import annotations

import csv
import json
import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any, TextIO

import pyarrow as pa
import pyarrow.parquet as pq

from .campaign_task import RUN_COLUMNS, SPEC_COLUMNS

__all__ = ["Journal", "read_journal", "table_columns", "write_tables"]

JOURNAL = "missions.jsonl"


def read_journal(path: str | Path) -> list[dict[str, Any]]:
    """Every complete row of a journal, in the order written (a torn or garbled line is skipped)."""
    path = Path(path)
    if not path.exists():
        return []
    rows = []
    with open(path, encoding="utf-8") as fh:
        for line in fh:
            line = line.strip()
            if not line:
                continue
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                continue
            if isinstance(row, dict) and "mission_id" in row:
                rows.append(row)
    return rows


class Journal:
    """Append-only row log of one campaign folder (see the module docstring)."""

    def __init__(self, out: str | Path):
        self.path = Path(out) / JOURNAL
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._fh: TextIO | None = None

    def latest(self) -> dict[str, dict[str, Any]]:
        """The newest row per mission id already in the journal."""
        return {r["mission_id"]: r for r in read_journal(self.path)}

    def done(self, tasks: Iterable, retry_failed: bool = False) -> set[str]:
        """Ids of the tasks whose row is in the journal with the same spec (and ``ok``, if retrying failures)."""
        latest = self.latest()
        out = set()
        for t in tasks:
            r = latest.get(t.mission_id)
            status = None if r is None or r.get("spec_hash") != t.spec_hash else r.get("status")
            if status == "ok" or (status == "failed" and not retry_failed):   # "lost" (worker died): rerun
                out.add(t.mission_id)
        return out

    def append(self, row: dict[str, Any]) -> None:
        """Write one row and make it durable before returning."""
        if self._fh is None:
            self._repair()
            self._fh = open(self.path, "a", encoding="utf-8")   # noqa: SIM115 (held open across appends; close())
        fh = self._fh
        assert fh is not None
        fh.write(json.dumps(row, allow_nan=True) + "\n")
        fh.flush()
        os.fsync(fh.fileno())

    def _repair(self) -> None:
        """Terminate a torn last line (left by a kill mid-write) so the next row starts on its own line."""
        if self.path.exists() and self.path.stat().st_size > 0:
            with open(self.path, "rb+") as fh:
                fh.seek(-1, os.SEEK_END)
                if fh.read(1) != b"\n":
                    fh.write(b"\n")

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None

    def __enter__(self) -> Journal:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def table_columns(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Spec columns, run columns, then every result column in first-seen order."""
    cols = list(SPEC_COLUMNS) + list(RUN_COLUMNS)
    seen = set(cols)
    for r in rows:
        for k in r:
            if k not in seen:
                seen.add(k)
                cols.append(k)
    return cols


def _arrow_type(values: list[Any]) -> pa.DataType:
    """float64 for numeric columns (ints too, except all-int ones), bool, else string."""
    present = [v for v in values if v is not None]
    if present and all(isinstance(v, bool) for v in present):
        return pa.bool_()
    if present and all(isinstance(v, int) and not isinstance(v, bool) for v in present):
        return pa.int64()
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        return pa.float64()
    return pa.string()


def write_tables(rows: Sequence[dict[str, Any]], out: str | Path) -> tuple[Path, Path]:
    """DIR/missions.parquet and DIR/missions.csv from the rows (one per mission)."""
    out = Path(out)
    cols = table_columns(rows)
    arrays = {}
    for c in cols:
        values = [r.get(c) for r in rows]
        kind = _arrow_type(values)
        if kind == pa.string():
            values = [None if v is None else (v if isinstance(v, str) else json.dumps(v)) for v in values]
        elif kind == pa.float64():
            values = [None if v is None else float(v) for v in values]
        arrays[c] = pa.array(values, type=kind)
    table = pa.table(arrays)
    parquet = out / "missions.parquet"
    tmp = parquet.with_suffix(".parquet.tmp")
    pq.write_table(table, tmp)
    os.replace(tmp, parquet)
    csv_path = out / "missions.csv"
    with open(csv_path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for r in rows:
            w.writerow(["" if r.get(c) is None else (repr(r[c]) if isinstance(r[c], float) else r[c]) for c in cols])
    return parquet, csv_path


def read_table(path: str | Path) -> list[dict[str, Any]]:
    """The rows of a missions.parquet, as dicts."""
    return pq.read_table(path).to_pylist()
