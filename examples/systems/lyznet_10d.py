"""LyZNet HSCC'24 example 4 (ex4a_10d_system_monolith): five coupled 2-state linear blocks with
quadratic couplings, 10 states, equilibrium at the origin.

The field is transcribed from LyZNet's ``examples/hscc24/ex4a_10d_system_monolith_domain_*.py``
(Zhou, Quartz, De Sterck, Liu, HSCC 2024). ``copies(k)`` is ``k`` decoupled copies of it
(``10 k`` states), the ladder's 20- and 30-state systems in ``benchmarks/bench_scale.py``.
Without ``LYAPUNOV_P`` the candidate is the default, P from A'P + PA = -I.
"""

from roa import System


def _block(x, o):
    x1, x2, x3, x4, x5, x6, x7, x8, x9, x10 = (x[o + i] for i in range(10))
    return (
        -x1 + 0.5 * x2 - 0.1 * x9**2,
        -0.5 * x1 - x2,
        -x3 + 0.5 * x4 - 0.1 * x1**2,
        -0.5 * x3 - x4,
        -x5 + 0.5 * x6 + 0.1 * x7**2,
        -0.5 * x5 - x6,
        -x7 + 0.5 * x8,
        -0.5 * x7 - x8,
        -x9 + 0.5 * x10,
        -0.5 * x9 - x10 + 0.1 * x2**2,
    )


def copies(k: int) -> System:
    """``k`` decoupled copies of the 10-state example (states x1_1 .. x10_k)."""

    def field(t, x, xp):
        out = ()
        for c in range(k):
            out += _block(x, 10 * c)
        return out

    names = tuple(
        f"x{i + 1}" if k == 1 else f"x{i + 1}_{c + 1}" for c in range(k) for i in range(10)
    )
    return System(
        name="lyznet-10d" if k == 1 else f"lyznet-10d-x{k}",
        field=field,
        equilibrium=(0.0,) * (10 * k),
        state_names=names,
        state_units=("1",) * (10 * k),
    )


SYSTEM = copies(1)
SYSTEM_20 = copies(2)
SYSTEM_30 = copies(3)
