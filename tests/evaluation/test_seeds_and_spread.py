"""The held-out protocol's seed sets and the spread of a figure over runs."""
from __future__ import annotations

import math

import pytest

from firenav_framework.evaluation.seeds import (MAX_COUNT, SEED_SETS, SeedError, describe_seeds,
                                                parse_seeds, seed_set_name)
from firenav_framework.evaluation.spread import median_interval_ranks, spread


def test_named_sets_ranges_and_lists():
    assert parse_seeds("tuning") == list(range(100, 140))
    assert parse_seeds("report") == list(range(1000, 1030))
    assert parse_seeds("fresh-report") == list(range(2000, 2030))
    assert parse_seeds("5") == [0, 1, 2, 3, 4]                # a count, as before
    assert parse_seeds("0-9") == list(range(10))
    assert parse_seeds("1,4,9") == [1, 4, 9]
    assert parse_seeds("3,7-9") == [3, 7, 8, 9]
    assert not set(SEED_SETS["tuning"]) & set(SEED_SETS["report"])
    for bad in ("x", "9-3", "0", "1,1", "tuning,100", "-4"):
        with pytest.raises(SeedError):
            parse_seeds(bad)
    assert seed_set_name(list(range(1000, 1030))) == "report"
    assert seed_set_name([100, 101]) == "part of tuning"
    assert seed_set_name([0, 1]) is None
    assert describe_seeds(list(range(1000, 1030))) == "1000-1029 (report)"
    assert describe_seeds([None]) == "recorded data (one run)"


def test_a_bare_count_above_the_bound_is_refused_with_the_range_to_give():
    assert parse_seeds(str(MAX_COUNT)) == list(range(MAX_COUNT))
    with pytest.raises(SeedError, match=r"seeds 0\.\.1000.*1001-1001 for seed 1001 alone"):
        parse_seeds("1001")
    with pytest.raises(SeedError, match="1000-1000"):
        parse_seeds(str(1000))
    assert parse_seeds("1000-1000") == [1000]                # one seed, as a range


def _coverage(n: int, k: int) -> float:
    """P(x_(k) <= median <= x_(n+1-k)) = 1 - 2 P(Binomial(n, 1/2) < k)."""
    return 1.0 - 2.0 * sum(math.comb(n, i) for i in range(k)) / 2.0 ** n


@pytest.mark.parametrize("n", [6, 10, 20, 30, 100])
def test_median_interval_is_the_narrowest_with_95_percent_coverage(n):
    k, hi = median_interval_ranks(n)
    assert hi == n + 1 - k
    assert _coverage(n, k) >= 0.95 > _coverage(n, k + 1)


def test_median_interval_known_ranks():
    assert median_interval_ranks(30) == (10, 21)     # the textbook ranks for n = 30
    assert median_interval_ranks(6) == (1, 6)
    assert median_interval_ranks(5) is None          # [min, max] covers only 93.75 %


def test_spread_of_values():
    s = spread([5.0, 1.0, 3.0, None, 2.0, 4.0, 6.0])
    assert (s.n, s.min, s.median, s.max) == (6, 1.0, 3.5, 6.0)
    assert (s.ci_low, s.ci_high) == (1.0, 6.0)
    # never converged counts as infinitely late: half of them -> the median is "never"
    c = spread([10.0, None, 20.0, None], none_is_inf=True)
    assert c.n == 4 and c.median == math.inf and c.as_dict()["median"] is None
    assert c.as_dict()["min"] == 10.0
    assert spread([None, None]).n == 0
