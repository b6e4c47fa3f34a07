"""Plotting helpers (matplotlib). The CLI selects the Agg backend; the library never does."""
