"""Integration: the reference and batch integrators, kernels and their cache, divergence, equilibria."""
