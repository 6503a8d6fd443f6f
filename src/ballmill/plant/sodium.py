"""What becomes of the sodium (plant.sodium.kind), each a function that takes the dried salt
stream and either leaves it a product or splits it.

- salt: Na2SO4 leaves at plant.na2so4_usd_per_t (set on the stream by the flowsheet).
- landfilled: the salt goes to landfill at the tip fee and the landfill factor of plant.landfill.
- bpmed: bipolar-membrane electrodialysis (units.SaltSplitting) returns NaOH and H2SO4; the
  plant buys that much less of each, so they leave as products at the bought prices and carry
  the bought products' factors as credits (the loop closed by system expansion: their purity is
  taken as the bought ones').
"""

from __future__ import annotations

import biosteam as bst

from .units import SaltSplitting


def salt(streams: dict, cfg, prices: dict[str, float], cepci: float) -> None:
    """Nothing to add: the salt is a product."""


def landfilled(streams: dict, cfg, prices: dict[str, float], cepci: float) -> None:
    bst.Mixer("U402", ins=streams["Na2SO4"], outs=bst.Stream("landfilled_salt", price=-prices["disposal"]))


def bpmed(streams: dict, cfg, prices: dict[str, float], cepci: float) -> None:
    c = cfg.sodium
    S = bst.Stream
    SaltSplitting("U401", ins=(streams["Na2SO4"], S("splitting_water", price=prices["process_water"])),
                  outs=(S("recovered_NaOH", price=prices["naoh"]), S("recovered_H2SO4", price=prices["h2so4"]),
                        S("splitting_condensate")),
                  kwh_per_kg_naoh=c.kwh_per_kg_naoh, current_efficiency=c.current_efficiency,
                  current_density_a_per_m2=c.current_density_a_per_m2, stack_to_membrane=c.stack_to_membrane,
                  life_yr=c.membrane_life_yr, product_wt_fraction=c.product_wt_fraction,
                  effects=c.concentrating_effects, key="bipolar_membrane_huang_2009", cepci=cepci)


FATES = {"salt": salt, "landfilled": landfilled, "bpmed": bpmed}
