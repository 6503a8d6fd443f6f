"""Published purchase-cost correlations (data/cost_correlations.csv), brought to the plant's
cost year by CEPCI: the evaporator's and crystallizer's own costs, and a second opinion beside
BioSTEAM's for every large unit.

Forms: power C = a + b S^n; exp_quadratic C = exp(a + b ln S + n ln^2 S).  S is the size in
the correlation's unit (the SI size times si_to_correlation).  A size above the range is split
into equal parallel units; one below it is priced at the smallest size (and flagged).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

from ..data import table

FILE = "cost_correlations.csv"


@dataclass(frozen=True)
class Priced:
    """A correlation's price for one size: $ in the cost year, parallel units, whether below range."""

    usd: float
    parallel: int
    below_range: bool


@cache
def correlation(key: str):
    rows = table(FILE).set_index("key")
    return rows.loc[key]


def base_cost(row, s: float) -> float:
    """$ at the correlation's own index for one unit of size s (correlation units)."""
    if row.form == "exp_quadratic":
        return math.exp(row.a + row.b * math.log(s) + row.n * math.log(s) ** 2)
    return row.a + row.b * s**row.n


def price(key: str, size_si: float, cepci_cost_year: float) -> Priced:
    """Purchase cost of `size_si` (SI units of the row) by the correlation `key`."""
    row = correlation(key)
    s = size_si * row.si_to_correlation
    parallel = max(1, math.ceil(s / row.s_max))
    each = s / parallel
    usd = parallel * base_cost(row, max(each, row.s_min)) * cepci_cost_year / row.cost_index
    return Priced(usd, parallel, each < row.s_min)
