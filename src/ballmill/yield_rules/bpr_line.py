"""bpr_line: the seed's yield line, Y = slope BPR + intercept (yields.py), the same in every mill."""

from __future__ import annotations

from .base import YieldRule


class BprLine(YieldRule):
    name = "bpr_line"
    dose = False
