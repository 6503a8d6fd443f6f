"""Checkpoint and restart: a run's full state (the fields each engine part names as its STATE,
the step, the recorder's samples so far) saved every so often, so that an interrupted run
continues where it was and ends with the same bits as an uninterrupted one (same thread
count).  A settled bed is the same state saved once, when the charge has settled and before
the walls move, for other runs of the same vessel and charge to start from.

The file is a NumPy .npz read with allow_pickle=False: the arrays as they are, everything else
as JSON text inside it (paths and object arrays marked so they come back as they were).  Cache
folders are shared between cluster jobs, and loading it runs no code (a pickle could).
"""

from __future__ import annotations

import json
import logging
import os
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..files import write_atomic

log = logging.getLogger(__name__)
META = "__meta__"
# the engine's field layout: 2 = fields sized by the particle capacity (particles.capacity), 3 =
# the same with each particle's wall-contact slots sized by the walls (walls.wall_slots), 4 = the
# same with an open contact's records its own, not its list slot's (neighbours.py); a state of
# another layout is not restored (the run starts afresh)
LAYOUT = 4


def encode(obj, arrays: list[np.ndarray]):
    """JSON-able form of obj; its arrays appended to `arrays` and referenced by index."""
    if isinstance(obj, np.ndarray):
        arrays.append(obj.astype(str) if obj.dtype == object else obj)
        return {"__array__": len(arrays) - 1, "object": obj.dtype == object}
    if isinstance(obj, Path):
        return {"__path__": str(obj)}
    if isinstance(obj, dict):
        return {"__dict__": [[encode(k, arrays), encode(v, arrays)] for k, v in obj.items()]}
    if isinstance(obj, tuple):
        return {"__tuple__": [encode(v, arrays) for v in obj]}
    if isinstance(obj, list):
        return [encode(v, arrays) for v in obj]
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def decode(obj, arrays):
    if isinstance(obj, list):
        return [decode(v, arrays) for v in obj]
    if not isinstance(obj, dict):
        return obj
    if "__array__" in obj:
        array = arrays[f"a{obj['__array__']}"]
        return array.astype(object) if obj["object"] else array
    if "__path__" in obj:
        return Path(obj["__path__"])
    if "__tuple__" in obj:
        return tuple(decode(v, arrays) for v in obj["__tuple__"])
    return {decode(k, arrays): decode(v, arrays) for k, v in obj["__dict__"]}


def write_state(path: Path, payload: dict, compress: bool = False) -> None:
    """payload as an .npz (its arrays as arrays, the rest as JSON text), written atomically."""
    arrays: list[np.ndarray] = []
    meta = encode(payload, arrays)
    save = np.savez_compressed if compress else np.savez

    def dump(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            save(f, **{META: np.array(json.dumps(meta))}, **{f"a{i}": a for i, a in enumerate(arrays)})
            f.flush()
            os.fsync(f.fileno())

    write_atomic(path, dump)


def read_state(path: Path) -> dict | None:
    """The payload write_state wrote to path; None when there is none or it is unreadable."""
    if not Path(path).exists():
        return None
    try:
        with np.load(path, allow_pickle=False) as arrays:
            return decode(json.loads(str(arrays[META])), arrays)
    except (OSError, ValueError, KeyError, zipfile.BadZipFile) as exc:
        log.warning("ignoring the unreadable state file %s (%s)", path, exc)
        return None


@dataclass(frozen=True)
class Checkpoint:
    """Where and how often (wall-clock seconds) a run saves itself; `key` names what it simulates
    (a checkpoint of another key or run label is ignored)."""

    path: Path
    every_wall_s: float
    key: str

    def save(self, engine, recorder, next_sample: int, label: str) -> None:
        """Write the state atomically: a temporary file renamed over the last checkpoint."""
        write_state(self.path, {"key": self.key, "layout": LAYOUT, "label": label, "next_sample": next_sample,
                                "engine": engine.state(), "recorder": recorder.state()})

    def resume(self, engine, recorder, label: str) -> int:
        """Restore engine and recorder from the checkpoint if it is this run's: the sample to
        continue from (0: start from the beginning)."""
        payload = read_state(self.path)
        if payload is None or payload.get("key") != self.key or payload.get("label") != label \
                or payload.get("layout") != LAYOUT:
            return 0
        engine.restore(payload["engine"])
        recorder.restore(payload["recorder"])
        log.info("%s: resumed from %s at t=%.4f s", label, self.path, engine.time_s)
        return payload["next_sample"]

    def remove(self) -> None:
        Path(self.path).unlink(missing_ok=True)


@dataclass(frozen=True)
class SettledBed:
    """A charge at rest in its vessel at step `step`, before any wall has moved: saved by the
    first run of a vessel and charge, restored by later runs that differ only in how the walls
    move after that, how long they run or what they average.  The wall motions are not saved
    (they are the runs' own); a restored run ends with the bits it would have had on its own."""

    path: Path
    key: str
    step: int

    def save(self, engine, recorder) -> None:
        write_state(self.path, {"key": self.key, "layout": LAYOUT, "step": self.step,
                                "engine": engine.state(),
                                "recorder": recorder.samples()}, compress=True)
        log.info("saved the settled bed (t=%.4f s) to %s", engine.time_s, self.path)

    def restore(self, engine, recorder) -> bool:
        """Start engine and recorder from the saved bed if there is one for this key and step."""
        payload = read_state(self.path)
        if payload is None or payload.get("key") != self.key or payload.get("step") != self.step \
                or payload.get("layout") != LAYOUT:
            return False
        engine.restore(payload["engine"])
        recorder.restore_samples(payload["recorder"])
        log.info("starting from the settled bed in %s (t=%.4f s), saved by an earlier run of this vessel and "
                 "charge", self.path, engine.time_s)
        return True
