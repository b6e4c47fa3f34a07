"""A share below 1 never prints as 1, one above 0 never as 0 (#25: "box share 1.000" for 0.99989)."""

from __future__ import annotations

import math

from hypothesis import given, strategies as st

from roa.shares import percent, share

INSIDE = st.floats(min_value=0.0, max_value=1.0, exclude_min=True, exclude_max=True)


@given(INSIDE, st.integers(min_value=0, max_value=8))
def test_a_share_strictly_inside_never_prints_as_an_end(x, decimals):
    text = share(x, decimals)
    assert 0 < float(text) < 1
    # and it is the value to the digits printed (rounding, never truncation past a digit)
    assert abs(float(text) - x) <= 0.5 * 10 ** -(len(text.split(".")[-1])) + 1e-17


@given(INSIDE)
def test_a_percentage_strictly_inside_never_prints_as_an_end(x):
    text = percent(x)
    assert text.endswith(" %") and 0 < float(text[:-2]) < 100


def test_known_values():
    assert share(0.99989) == "0.9999" and share(0.99999) == "0.99999"
    assert share(0.868123) == "0.868"
    assert share(1.0) == "1.000" and share(0.0) == "0.000"
    assert share(0.0004) == "0.0004"
    assert share(1 - 2**-53) == "0.9999999999999999"
    assert share(0.99989, count=23, of=200000, what="outside") == "0.9999 (23 of 200000 outside)"
    assert percent(0.99989) == "99.99 %" and percent(0.999999) == "99.9999 %"
    assert percent(1.0) == "100.00 %"
    assert share(math.nan) == "nan"


def test_sampled_share_counts_the_misses_only_where_rounding_hides_them():
    from roa.shares import sampled_share

    assert sampled_share(0.999885, 200000) == "0.9999 (23 of 200000 outside)"
    assert sampled_share(0.867565, 200000) == "0.868"
    assert sampled_share(1.0, 200000) == "1.000"
    assert sampled_share(0.999885, None) == "0.9999"
