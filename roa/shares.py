"""Printing shares and fractions: a value below 1 never reads as 1 (nor one above 0 as 0).

``f"{0.99989:.3f}"`` is ``"1.000"``: a report saying "box share 1.000" when 23 of 200,000 samples
lie outside claims what was not found. :func:`share` prints as many decimals as it takes::

    >>> share(0.868123)
    '0.868'
    >>> share(0.99989)
    '0.9999'
    >>> share(0.99989, count=23, of=200_000, what="outside")
    '0.9999 (23 of 200000 outside)'
    >>> share(1.0), share(0.0)
    ('1.000', '0.000')

A confidence interval's bounds are rounded outward instead (:func:`interval`): its upper bound
``0.9999999999999999`` (1 up to rounding) reads ``1.0000``::

    >>> interval(0.99851, 0.9999999999999999, 4)
    '0.9985-1.0000'
"""

from __future__ import annotations

import math

#: Decimals at most: 17 tell any two float64 values in [0, 1] apart.
MAX_DECIMALS = 17


def _fixed(v: float, decimals: int, top: float, inside: bool) -> str:
    """``v`` with ``decimals`` decimals; when ``inside`` (``0 < v < top``), with more decimals,
    up to :data:`MAX_DECIMALS`, until the printed value is strictly between 0 and ``top``."""
    d = max(0, int(decimals))
    text = f"{v:.{d}f}"
    while inside and d < MAX_DECIMALS and not 0 < float(text) < top:
        d += 1
        text = f"{v:.{d}f}"
    return text


def share(
    x: float, decimals: int = 3, *, count: int | None = None, of: int | None = None,
    what: str = "",
) -> str:  # fmt: skip
    """``x`` (a share in [0, 1]) with ``decimals`` decimals, or more where that would round it
    to 1 or 0 when it is not; with ``count`` and ``of``, followed by ``(count of of what)``.

    Values outside [0, 1] and non-finite values print with ``decimals`` decimals (``nan``,
    ``inf``): the guarantee is that ``0 < x < 1`` never prints as a string whose value is 0 or 1.
    """
    x = float(x)
    text = _fixed(x, decimals, 1.0, math.isfinite(x) and 0 < x < 1)
    if math.isfinite(x) and 0 < x < 1:
        if not 0 < float(text) < 1:  # below 1e-17 or within 1e-17 of 1: the shortest repr
            text = repr(x)
    if count is not None and of is not None:
        text += f" ({count} of {of}{' ' + what if what else ''})"
    return text


def interval(lo: float, hi: float, decimals: int = 4, *, scale: float = 1.0,
             unit: str = "") -> str:  # fmt: skip
    """A confidence interval ``[lo, hi]`` (times ``scale``) with ``decimals`` decimals, rounded
    outward (``lo`` down, ``hi`` up: the printed interval contains the computed one), as
    ``lo-hi`` followed by ``unit``. Non-finite bounds print as they are."""
    d = max(0, int(decimals))

    def bound(v: float, up: bool) -> str:
        v = float(v) * scale
        if not math.isfinite(v):
            return f"{v}"
        k = v * 10**d
        r = math.ceil(k) if up else math.floor(k)
        if abs(k - round(k)) <= 1e-9 * max(1.0, abs(k)):  # already on the grid (float noise)
            r = round(k)
        return f"{r / 10**d:.{d}f}"

    return f"{bound(lo, False)}-{bound(hi, True)}{unit}"


def percent(x: float, decimals: int = 2) -> str:
    """``100 x`` followed by `` %``, with the guarantee of :func:`share` (a share below 1 never
    prints as ``100.00 %``, one above 0 never as ``0.00 %``)."""
    x = float(x)
    p = 100 * x
    text = _fixed(p, decimals, 100.0, math.isfinite(x) and 0 < x < 1)
    if math.isfinite(x) and 0 < x < 1:
        if not 0 < float(text) < 100:  # 100 x rounded to 100 or is below 1e-17
            text = repr(p) if p < 100 else "99.99999999999999"
    return f"{text} %"


def sampled_share(
    fraction: float, samples: int | None, what: str = "outside", decimals: int = 3
) -> str:
    """A share measured on ``samples`` samples; where ``decimals`` decimals would round it to 1,
    followed by how many samples it misses (``0.9999 (23 of 200000 outside)``), else
    :func:`share` alone."""
    if samples and 0 <= fraction < 1 and float(f"{fraction:.{decimals}f}") >= 1:
        missed = round((1 - fraction) * samples)
        return share(fraction, decimals, count=missed, of=int(samples), what=what)
    return share(fraction, decimals)
