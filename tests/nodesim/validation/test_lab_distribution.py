"""Issue 21 build 2: a published lab figure is one run, so it is compared with the distribution of ours
(nodesim.validation.within_band: median, 5-95 % band, the percentile of the published value; ok inside the band),
one batched run per scenario serving all its rows, a summary row of the share inside, orderings on medians."""

import math

import numpy as np
import pytest

from nodesim.validation import Check, checks_lab, percentile_of, within_band


def test_a_band_row_is_ok_inside_the_5_95_band_and_reports_median_band_and_percentile():
    values = np.arange(101.0)  # percentiles = values
    inside = within_band("x", "thesis", values, 30.0)
    assert inside.ok and inside.ours == 50.0 and (inside.band_p5, inside.band_p95) == (5.0, 95.0)
    assert inside.published_percentile == pytest.approx(100 * 30.5 / 101)  # 30 below, one tie
    assert inside.realizations == 101 and "5-95 %" in inside.tolerance
    assert not within_band("x", "thesis", values, 4.0).ok and not within_band("x", "thesis", values, 96.0).ok
    assert within_band("x", "thesis", values, 5.0).ok and within_band("x", "thesis", values, 95.0).ok


def test_a_printed_zero_is_the_interval_below_its_resolution():
    values = np.linspace(0.0001, 0.004, 200)  # 5th percentile 0.0003
    row = within_band("x", "thesis", values, 0.0, printed_below=0.0005)
    assert row.ok and row.published_percentile > 0  # [0, 0.0005) reaches into the band
    assert not within_band("x", "thesis", values + 0.001, 0.0, printed_below=0.0005).ok


def test_percentile_counts_ties_half_and_nan_runs_are_left_out():
    assert percentile_of([1.0, 2.0, 2.0, 3.0], 2.0) == 50.0
    row = within_band("x", "thesis", [1.0, float("nan"), 3.0, 2.0], 2.0)
    assert row.realizations == 3 and row.ours == 2.0
    assert not within_band("x", "thesis", [float("nan"), 1.0], 1.0).ok  # one finite run is no distribution


def test_binomial_lower_quantile():
    def below(k, n, p):  # P(X < k)
        return sum(math.comb(n, j) * p**j * (1 - p) ** (n - j) for j in range(k))
    for n in (10, 19, 40):
        k = checks_lab.binomial_lower_quantile(n, 0.9)
        assert below(k, n, 0.9) <= 0.05 < below(k + 1, n, 0.9)
    assert checks_lab.binomial_lower_quantile(19, 0.9) == 15


@pytest.fixture(scope="module")
def rows():
    return checks_lab.band_rows()


def test_every_published_lab_value_is_a_band_row_of_at_least_64_runs(rows):
    names = [c.name for c in rows]
    assert len(rows) == 2 * len(checks_lab.TABLE_4_22) + 3 + 4  # table 4.22, single updates, two nodes
    assert all(c.realizations == checks_lab.REALIZATIONS >= 64 and c.kind == "reproduction" for c in rows)
    assert all(c.band_p5 <= c.ours <= c.band_p95 and 0.0 <= c.published_percentile <= 100.0 for c in rows)
    assert all(c.ok == (c.band_p5 <= c.published <= c.band_p95) for c in rows if c.published != 0.0)
    assert "lab two nodes: node B: RMS azimuth error [deg]" in names
    row = next(c for c in rows if c.name == "lab 20 s / 10 s timeout: RMS azimuth error [deg]")
    values = checks_lab.lab_metrics("windowed_20s_10s")["rms_azimuth_error_deg"]
    assert row.ours == pytest.approx(np.median(values)) and row.band_p95 == pytest.approx(np.percentile(values, 95))


def test_the_mean_of_three_single_update_runs_draws_three_independent_runs(rows):
    row = next(c for c in rows if "0.05/0.1/0.2 Hz: mean" in c.name)
    azi = [checks_lab.lab_metrics(n)["rms_azimuth_error_deg"] for n in checks_lab.SINGLE_MEAN]
    R = azi[0].size
    r = 5  # realization 5 of 0.2 Hz, 5 + R/3 of 0.1 Hz, 5 + 2R/3 of 0.05 Hz
    expected = (azi[0][r] + azi[1][(r + R // 3) % R] + azi[2][(r + 2 * R // 3) % R]) / 3
    mean = sum(np.roll(a, -(i * R // 3)) for i, a in enumerate(azi)) / 3
    assert mean[r] == pytest.approx(expected) and row.ours == pytest.approx(np.median(mean))


def test_the_summary_row_counts_the_band_rows(rows):
    (summary,) = checks_lab.band_summary()
    inside = sum(c.ok for c in rows)
    assert summary.kind == "reproduction" and summary.published == 0.9
    assert summary.ours == pytest.approx(inside / len(rows))
    assert summary.ok == (inside >= checks_lab.binomial_lower_quantile(len(rows), 0.9))
    assert f"{inside} of {len(rows)}" in summary.note


def test_orderings_compare_medians_azimuth_with_azimuth():
    chain, b_over_a, _ = checks_lab.orderings()
    med = [checks_lab.median(n, "rms_azimuth_error_deg") for n in checks_lab.ORDER_CHAIN]
    assert chain.ok == all(a < b for a, b in zip(med, med[1:]))
    assert chain.ours == pytest.approx(med[-1] / med[1])
    assert "azimuth" in b_over_a.name and b_over_a.published == pytest.approx(0.761 / 0.442)
    assert "medians" in b_over_a.note and "medians" in chain.note


def test_check_without_band_fields_keeps_its_old_shape():
    c = Check("a", "s", 1.0, 1.0, "rel 1", True)
    assert c.band_p5 is c.band_p95 is c.published_percentile is c.realizations is None
    assert {"band_p5", "band_p95", "published_percentile", "realizations"} <= set(c.as_dict())
