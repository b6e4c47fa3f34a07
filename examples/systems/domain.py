"""Two polynomial systems with a declared domain: a certified set must stay inside it.

* ``VDP``: the time-reversed Van der Pol oscillator with V = d' P d, P = [[1.5, -0.5], [-0.5, 1]]
  (Chesi's benchmark V, largest level about 2.3045 without a domain) on the strip ``|x1| < 0.5``.
  The least V on the strip's boundary is ``0.25 / (P^-1)_11 = 0.25 / 0.8 = 0.3125`` (the
  minimum of ``d' P d`` subject to ``d1 = 0.5``), so no level from 0.3125 up can be certified.
* ``RING``: the 5-cell ring ``x_i' = -x_i + x_{i+1} / 2 + x_i^3`` with V = |x|^2 on the slab
  ``|x1| < 0.3``: the least V on the boundary is ``0.3^2 = 0.09``.
"""

from roa import System

P_VDP = ((1.5, -0.5), (-0.5, 1.0))
#: The least V on the boundary of each domain (derived in the module docstring).
BOUNDARY_VDP = 0.3125
BOUNDARY_RING = 0.09


def _vdp(t, x, xp):
    return (-x[1], x[0] - x[1] + x[0] ** 2 * x[1])


def _ring(t, x, xp):
    return tuple(-x[i] + x[(i + 1) % 5] / 2 + x[i] ** 3 for i in range(5))


VDP = System(name="vanderpol-strip", field=_vdp, equilibrium=(0.0, 0.0),
             state_names=("x1", "x2"), state_units=("1", "1"),
             margin=lambda x, xp: (x[0] + 0.5) * (0.5 - x[0]), domain_description="|x1| < 0.5",
             lyapunov=P_VDP)  # fmt: skip
RING = System(name="ring-5-slab", field=_ring, equilibrium=(0.0,) * 5,
              state_names=tuple(f"x{i + 1}" for i in range(5)), state_units=("1",) * 5,
              margin=lambda x, xp: (x[0] + 0.3) * (0.3 - x[0]), domain_description="|x1| < 0.3",
              lyapunov=tuple(tuple(float(i == j) for j in range(5)) for i in range(5)))  # fmt: skip
SYSTEM = VDP
