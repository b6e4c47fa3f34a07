"""Plotting helpers (matplotlib, Agg backend)."""

import matplotlib

matplotlib.use("Agg")
