"""A surrogate of the drum DEM: dimensionless groups in (space), DEM runs on a space-filling
design (training), Gaussian processes with their uncertainty (model), and the cheapest mill
it makes possible (optimise)."""
