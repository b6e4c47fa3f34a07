"""``roa.certify``: find a level of a Lyapunov candidate and prove it, as a pipeline of strategies.

:func:`certify` returns a :class:`Certificate`. The strategies (:mod:`.strategies`) are objects:
validators (:class:`IntervalValidator`, :class:`SosValidator`, :class:`AutoValidator`), level proposers (:class:`GivenLevel`,
:class:`CandidateLevel`, :class:`SosLevel`, :class:`SampledLevel`) and sources of V
(:class:`VsIteration`, :class:`CuttingPlanes`, yielding :class:`Candidate` pairs of V and its
proposer); :mod:`.pipeline` chains them with a :class:`RetryPolicy` and a :class:`WitnessRefuter`,
and :func:`plan` maps :func:`certify`'s arguments (names, numbers, shorthands) to those objects.
A validator or proposer declares what it can do (:class:`ValidatorBase`, :class:`ProposerBase`).
"""

import lazy_loader as _lazy

# The public names are listed once, in __init__.pyi: it gives __all__, the lazy imports and the types.
__getattr__, __dir__, __all__ = _lazy.attach_stub(__name__, __file__)
