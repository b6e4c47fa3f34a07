"""Certified regions of attraction: SOS certificates, rigorous interval validation, Lyapunov search."""
