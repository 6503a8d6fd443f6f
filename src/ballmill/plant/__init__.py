"""The whole plant around the mill as a BioSTEAM system: chemicals (chemicals.py), its own
units where BioSTEAM has none (units.py: the ball mill among them), the flowsheet
(system.py), NREL's TEA and the staffing rule (tea.py), the footprint (footprint.py), the
plant as a record and tables (model.py), published cost correlations (correlations.py) and
BioSTEAM's Model for the uncertainty (uncertainty.py).

BioSTEAM takes seconds to import: only the plant study imports this package.
"""

import logging

logging.getLogger("pint.util").setLevel(logging.ERROR)  # thermosteam's pint warns of its own deprecations
