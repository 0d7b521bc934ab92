"""``Latency.extend`` buckets many samples with numpy, and must bucket them exactly
as ``add`` does one at a time with math's log: on random samples, on every bucket's
edge and the floats either side of it (where numpy's log may be a last digit off),
at zero and below."""

from __future__ import annotations

import math
import random

import numpy as np

from analyzer.analysis.stats import _LOG_STEP, Latency


def test_extend_buckets_as_add_does():
    rng = random.Random(3)
    xs = [rng.uniform(0, 0.5) for _ in range(50_000)] + [0.0, -0.001, 1e-10, 2.0]
    for k in range(-900, -50):   # bucket k starts at exp(k * step)
        edge = math.exp(k * _LOG_STEP)
        xs += [edge, math.nextafter(edge, 0), math.nextafter(edge, 1)]
    one, many = Latency(), Latency()
    for x in xs:
        one.add(x)
    many.extend(np.array(xs))
    assert (many.n, many.min, many.max, many.zero) == (one.n, one.min, one.max, one.zero) == \
        (len(xs), -0.001, 2.0, 3)
    assert many.buckets == one.buckets
    assert many.quantile(0.5) == one.quantile(0.5) and many.quantile(0.95) == one.quantile(0.95)


def test_a_few_samples_go_one_by_one():
    few, one = Latency(), Latency()
    few.extend([0.01, 0.02])
    for x in (0.01, 0.02):
        one.add(x)
    assert few.buckets == one.buckets and few.n == 2
