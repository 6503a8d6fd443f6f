"""Checkpoint and restart: a run's full state (every engine field, the step, the recorder's
samples so far) saved every so often, so that an interrupted run continues where it was and
ends with the same bits as an uninterrupted one (same thread count)."""

from __future__ import annotations

import logging
import os
import pickle
from dataclasses import dataclass
from pathlib import Path

from ..files import write_atomic

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Checkpoint:
    """Where and how often (simulated seconds) a run saves itself; `key` names what it simulates
    (a checkpoint of another key or run label is ignored)."""

    path: Path
    every_s: float
    key: str

    def save(self, engine, recorder, next_sample: int, label: str) -> None:
        """Write the state atomically: a temporary file renamed over the last checkpoint."""
        payload = {"key": self.key, "label": label, "next_sample": next_sample, "engine": engine.state(),
                   "recorder": recorder.state()}

        def dump(tmp: Path) -> None:
            with open(tmp, "wb") as f:
                pickle.dump(payload, f, protocol=pickle.HIGHEST_PROTOCOL)
                f.flush()
                os.fsync(f.fileno())

        write_atomic(self.path, dump)

    def resume(self, engine, recorder, label: str) -> int:
        """Restore engine and recorder from the checkpoint if it is this run's: the sample to
        continue from (0: start from the beginning)."""
        path = Path(self.path)
        if not path.exists():
            return 0
        try:
            with open(path, "rb") as f:
                payload = pickle.load(f)
        except (OSError, EOFError, pickle.UnpicklingError) as exc:
            log.warning("ignoring the unreadable checkpoint %s (%s)", path, exc)
            return 0
        if payload.get("key") != self.key or payload.get("label") != label:
            return 0
        engine.restore(payload["engine"])
        recorder.restore(payload["recorder"])
        log.info("%s: resumed from %s at t=%.4f s", label, path, engine.time_s)
        return payload["next_sample"]

    def remove(self) -> None:
        Path(self.path).unlink(missing_ok=True)
