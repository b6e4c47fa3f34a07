"""Typed errors of ``roa``.

Library calls raise these with messages that name the *argument* (``level``, ``options.max_boxes``),
never a command-line flag; :func:`roa.cli.main` turns :class:`RoaInputError` into exit code 2 and
lets every other failure surface with its own message and exit code 1.

Analysis outcomes (refuted, inconclusive, diverged, ...) are never errors: they are statuses of the
returned result objects.
"""

from __future__ import annotations


class RoaError(Exception):
    """Base class of every error raised on purpose by ``roa``."""


class RoaInputError(RoaError, ValueError):
    """An argument is invalid: wrong type, shape, range, or inconsistent with another argument.

    The message names the argument and what is allowed. Subclass of ``ValueError`` so that callers
    catching ``ValueError`` keep working.
    """


class SystemDefinitionError(RoaInputError):
    """A system (or a system file) cannot be used: it fails to load, or its field is malformed."""


class ResultsError(RoaError):
    """Stored results are missing, unreadable or inconsistent (a run directory, a summary file)."""


class SolverError(RoaError, RuntimeError):
    """An external solver or cluster failed in a way no status can describe (e.g. it is absent)."""


class TimeLimitReached(BaseException):
    """A step ran past its wall-clock limit (:mod:`roa.stage_limit`). Like ``KeyboardInterrupt``
    it derives from ``BaseException``: handlers of ordinary failures (``except Exception``) must
    not take a stopped step for a failed one and go on."""


def require(condition: bool, message: str) -> None:
    """Raise :class:`RoaInputError` with ``message`` unless ``condition`` holds."""
    if not condition:
        raise RoaInputError(message)
