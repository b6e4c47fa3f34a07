"""A 2-D polynomial map with a closed-form largest level (the built-in ``cubic-map``):
``x+ = (lam + mu x1^2) R(theta) x``; with ``V = |x|^2 / (1 - lam^2)`` (the solution of
``A'PA - P = -I``) the largest level is ``1 / (mu (1 + lam))`` (:mod:`roa.systems.cubic_map`).

    roa certify --system cubic-map --check-above 1.01
    roa certify --system examples/systems/cubic_map.py:SYSTEM
"""

from roa.systems.cubic_map import cubic_map, optimum

SYSTEM = cubic_map(lam=0.5, mu=1.0, theta=0.7)
OPTIMUM = optimum(0.5, 1.0)
