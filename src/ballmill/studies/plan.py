"""A study's plan: the record known before simulating and how to produce the rest."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path


@dataclass
class Plan:
    """A checked run: the record's inputs known before simulating, and how to produce the rest."""

    record: dict
    execute: Callable[[Path], dict]


def prefixed(record: dict, prefix: str) -> dict:
    return {f"{prefix}_{k}": v for k, v in record.items()}
