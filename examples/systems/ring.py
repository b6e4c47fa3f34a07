"""A ring of n coupled cells with a destabilising cubic term, V = |x|^2.

    x_i' = -x_i + a x_{i+1} + x_i^3      (indices mod n, a = 0.5)

``V' = 2 sum(-x_i^2 + a x_i x_{i+1} + x_i^4)`` couples every cell to its neighbours: the
variables' interaction graph is the n-cycle (one connected component, no decoupled blocks), and a
dense degree-4 SOS program over all n variables has 465 + 30 monomials at n = 30. The sparse
route (``roa.search._sos_program.clique_pattern``) uses a chordal extension of the cycle (n - 2 triangles). At
``x = e_1``, ``V' = 2 (-1 + 1) = 0`` with ``V = 1``: the largest level is below 1 (about 0.9323,
the ladder's multistart SLSQP in ``benchmarks/bench_scale.py``).
"""

from roa import System

A = 0.5


def ring(n: int, a: float = A) -> System:
    """The ring of ``n`` cells with coupling ``a`` (``|a| < 1``: V' negative definite)."""

    def field(t, x, xp):
        return tuple(-x[i] + a * x[(i + 1) % n] + x[i] ** 3 for i in range(n))

    eye = [[float(i == j) for j in range(n)] for i in range(n)]
    return System(name=f"ring-{n}", field=field, equilibrium=(0.0,) * n,
                  state_names=tuple(f"x{i + 1}" for i in range(n)),
                  state_units=("1",) * n, lyapunov=eye)  # fmt: skip


SYSTEM = ring(8)
SYSTEM_20 = ring(20)
SYSTEM_30 = ring(30)
