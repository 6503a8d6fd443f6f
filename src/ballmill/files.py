"""Files written whole or not at all: a temporary name in the same folder, then a rename, so
an interrupted job never leaves a half-written record or cache entry that looks finished; a
lock so that two jobs needing the same cache entry compute it once; and Parquet tables read
without Arrow's thread pools."""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq


def write_atomic(path: str | Path, write: Callable[[Path], None]) -> None:
    """write(tmp) to a temporary name unique to this writer beside path, then rename it onto
    path (two processes writing the same file each leave it whole)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        write(Path(tmp))
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_text(path: str | Path, text: str) -> None:
    write_atomic(path, lambda tmp: tmp.write_text(text))


def write_json(path: str | Path, obj) -> None:
    write_text(path, json.dumps(obj, indent=2, default=str))


def read_json(path: str | Path) -> dict | None:
    """The JSON object in path; None when it is missing, truncated or not an object."""
    try:
        obj = json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return None
    return obj if isinstance(obj, dict) else None


def read_parquet(path: str | Path) -> pd.DataFrame:
    """The table in a Parquet file, read on the calling thread. pandas.read_parquet starts Arrow's
    I/O and CPU thread pools (even with use_threads=False), and a pool worker still alive when
    the interpreter exits aborts it ("terminate called without an active exception", exit -6)
    after its work is done: 3 exits in 200 on 2 busy cores (apache/arrow#34314)."""
    return pq.ParquetFile(path).read(use_threads=False).to_pandas(use_threads=False)


@contextmanager
def exclusive(path: str | Path):
    """Hold an advisory lock on the file `path` (created) for the block: another process asking
    for it waits until this one is done (or dies), so a cache entry is computed once."""
    import fcntl

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)
