"""roa: region-of-attraction verification toolkit.

Every analysis is one call returning a frozen result with a ``status``::

    import roa
    from roa.systems.vanderpol import vanderpol

    system = vanderpol()
    roa.simulate(system, [0.5, 0.5])                  # Trajectory, RunStatus
    roa.level_search(system, shape="level")           # LevelSearchResult, LevelStatus
    roa.certify(system)                               # Certificate, Verdict
    roa.basin(system, roa.grid_slice(system, ("x1", "x2"), [(-3, 3), (-3, 3)], (50, 50)))

Systems are small frozen dataclasses (:class:`roa.System`) whose vector field is written once
against an array namespace (numpy, CasADi, sympy, intervals), so that simulation, level-set search,
certification and Monte Carlo all work on the same definition.
"""

import lazy_loader as _lazy

#: The public API is listed once, in ``__init__.pyi`` (this package's and each subpackage's): the
#: stub gives ``__all__``, the lazy imports and the types static checkers see. Each name is
#: imported on first use (PEP 562), so that ``import roa`` and ``roa --help`` stay fast: cvxpy,
#: CasADi, numba, sympy, matplotlib and scipy.optimize are imported only by the analyses that
#: need them. Modules whose names start with ``_`` are private.
__getattr__, __dir__, __all__ = _lazy.attach_stub(__name__, __file__)
__version__ = "0.1.0"
