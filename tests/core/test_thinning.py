"""Thinned plot series keep every extremum."""

from __future__ import annotations

import itertools

import numpy as np

from app.core.thinning import thin_minmax, thin_part


def test_short_series_are_kept_whole():
    t = np.arange(100.0)
    np.testing.assert_array_equal(thin_minmax(t, np.sin(t)[None], 2000), np.arange(100))


def test_every_bucket_extremum_and_the_global_ones_survive():
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 600.0, 60_000)
    curves = np.stack(
        [np.sin(t) + 0.1 * rng.standard_normal(t.size), np.cumsum(rng.standard_normal(t.size))]
    )
    curves[0, 31_234] = 50.0  # a one-sample spike
    curves[1, 7] = np.nan
    keep = thin_minmax(t, curves, 2000)
    assert len(keep) <= 2000
    assert np.all(np.diff(keep) > 0) and keep[0] == 0 and keep[-1] == t.size - 1
    for curve in curves:
        assert np.nanargmax(curve) in keep and np.nanargmin(curve) in keep
        kept = curve[keep]
        assert np.nanmax(kept) == np.nanmax(curve) and np.nanmin(kept) == np.nanmin(curve)
    # No peak hides between kept samples: with 2000 points for 2 curves, one drawn min/max pair
    # per curve covers at most 2·2·60000/2000 = 120 samples; every window's extremes show up
    # within that distance of the window.
    reach = 2 * len(curves) * t.size // 2000
    for start in range(0, t.size, 600):
        stop = start + 600
        inside = keep[(keep >= start - reach) & (keep < stop + reach)]
        for curve in curves:
            window = curve[start:stop]
            if np.all(np.isnan(window)):
                continue
            assert np.nanmax(curve[inside]) >= np.nanmax(window)
            assert np.nanmin(curve[inside]) <= np.nanmin(window)


def brute_force(t, curves, max_points):
    """Bucket by bucket, curve by curve: the first smallest and largest finite sample."""
    n = len(t)
    buckets = max(1, (max_points - 2) // (2 * len(curves)))
    edges = np.linspace(0, n, buckets + 1).astype(int)
    keep = {0, n - 1}
    for start, stop in itertools.pairwise(edges):
        for curve in curves:
            finite = [i for i in range(start, stop) if np.isfinite(curve[i])]
            if finite:
                keep.add(min(finite, key=lambda i: (curve[i], i)))
                keep.add(min(finite, key=lambda i: (-curve[i], i)))
    return np.array(sorted(keep))


def test_the_kept_samples_are_each_buckets_first_extrema():
    rng = np.random.default_rng(11)
    for n, c in ((2001, 1), (5706, 12), (12_345, 6), (9000, 3)):
        curves = np.round(np.cumsum(rng.standard_normal((c, n)), axis=1))  # ties, on purpose
        curves[rng.uniform(size=curves.shape) < 0.01] = np.nan
        curves[:, 100:400] = np.nan  # whole buckets without a finite sample
        curves[0, 5] = np.inf
        np.testing.assert_array_equal(
            thin_minmax(np.arange(n), curves, 2000), brute_force(np.arange(n), curves, 2000)
        )


def test_curves_thinned_in_parts_keep_what_all_at_once_keep():
    """The union of the parts' picks (the attitude plot thins its fixed curves once) is the
    thinning of all the curves together, for plot sizes either side of the point budget."""
    rng = np.random.default_rng(11)
    for n, count, split in ((60_000, 6, 4), (59_913, 10, 4), (7_001, 12, 5), (1_500, 6, 4)):
        t = np.linspace(0.0, n / 100.0, n)
        curves = np.cumsum(rng.standard_normal((count, n)), axis=1)
        curves[0, rng.integers(0, n, 30)] = np.nan
        curves[split, : n // 3] = 0.0  # a flat stretch: ties resolve alike
        whole = thin_minmax(t, curves)
        parts = np.union1d(thin_part(t, curves[:split], count), thin_part(t, curves[split:], count))
        np.testing.assert_array_equal(parts, whole)


def test_bucket_by_bucket_and_gathered_extrema_agree(monkeypatch):
    """The two ways `thin_minmax` finds each bucket's extrema pick the same samples (ties:
    the first), on a plot of several curves and of one."""
    import app.core.thinning as thinning

    rng = np.random.default_rng(5)
    t = np.linspace(0.0, 599.0, 59_913)
    for curves in (np.cumsum(rng.standard_normal((12, t.size)), axis=1), np.sin(t)[None]):
        curves[:, 1000:5000] = 1.0  # flat: ties everywhere
        by_bucket = thin_minmax(t, curves)
        monkeypatch.setattr(thinning, "LOOP_BUCKETS", 0)
        gathered = thin_minmax(t, curves)
        monkeypatch.setattr(thinning, "LOOP_BUCKETS", 10**6)
        np.testing.assert_array_equal(thin_minmax(t, curves), gathered)
        np.testing.assert_array_equal(by_bucket, gathered)
        monkeypatch.undo()
