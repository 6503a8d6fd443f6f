"""Hauling bales by truck between states (data/haulage.csv, data/population_centres.csv): the
road distance between two states' centres of population (great circle x circuity), and the
truck's price and greenhouse gas per tonne-km."""

from __future__ import annotations

import math

from ..data import lookup

EARTH_RADIUS_KM = 6371.0088  # IUGG mean radius
KM_PER_MILE = 1.609344
T_PER_SHORT_TON = 0.90718474


def value(item: str) -> float:
    return float(lookup("haulage.csv", "item", item, "value"))


def great_circle_km(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Distance on the sphere (haversine) between two points given in degrees."""
    p1, p2, dp, dl = map(math.radians, (lat1, lat2, lat2 - lat1, lon2 - lon1))
    a = math.sin(dp / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(dl / 2) ** 2
    return 2 * EARTH_RADIUS_KM * math.asin(math.sqrt(a))


def road_km(a: str, b: str) -> float:
    """Road distance between two states' centres of population: great circle x the circuity."""
    at = {c: [float(lookup("population_centres.csv", "code", c, k)) for k in ("latitude_deg", "longitude_deg")]
          for c in (a, b)}
    return great_circle_km(*at[a], *at[b]) * value("road_circuity")


def usd_per_t_km() -> float:
    """A truck's cost per mile over its payload, per tonne-km."""
    return value("truck_cost_usd_per_mile") / KM_PER_MILE / value("truck_payload_t")


def kg_co2e_per_t_km() -> float:
    """The truck's kg CO2e per short ton-mile, per tonne-km."""
    return value("truck_kg_co2e_per_short_ton_mile") / (T_PER_SHORT_TON * KM_PER_MILE)
