"""Every validation row says what it is (``reproduction``, ``self_consistency`` or ``hypothesis``): the Allan
rows read back their own inputs, the two-node ordering compares azimuth with the published azimuth and yaw only
with our own yaw, and a row's kind is one of the three."""

import math

import pytest

from nodesim.validation import KINDS, Check, checks_lab, checks_sensors, counts_by_kind, within_factor


def test_allan_rows_are_self_consistency_and_named_so():
    rows = checks_sensors.allan_closed_loop()
    assert len(rows) == 8
    for c in rows:
        assert c.kind == "self_consistency"
        assert c.name.startswith("Allan self-consistency ") and "read back" in c.name
        assert "simulated with these values" in c.source


def test_only_passed_through_datasheet_figures_are_self_consistency():
    rows = checks_sensors.datasheet_mapping()
    read_back = {c.name for c in rows if c.kind == "self_consistency"}
    assert read_back == {"VN-100T datasheet -> gyro_drift_deg_s", "VN-100T datasheet -> gyro_arw_deg_s_per_sqrt_hz"}
    assert {c.kind for c in rows} == {"reproduction", "self_consistency"}


@pytest.fixture(scope="module")
def two_node_orderings():
    return {c.name: c for c in checks_lab.orderings()}


def test_node_b_over_a_compares_azimuth_with_the_published_azimuth(two_node_orderings):
    med = lambda key: checks_lab.median("two_nodes_0p8hz", key)  # noqa: E731 (the rows compare medians)
    azi = two_node_orderings["lab ordering: RMS azimuth error node B / node A (hop count)"]
    assert azi.kind == "reproduction"
    assert azi.ours == pytest.approx(med("node2_rms_azimuth_error_deg") / med("node1_rms_azimuth_error_deg"))
    assert azi.published == pytest.approx(0.761 / 0.442)
    assert azi.ok == checks_lab.excess_within_factor(azi.ours, azi.published)
    if not azi.ok:
        assert "accelerometer noise" in azi.note and "reference error" in azi.note  # the reason is in the row


@pytest.mark.parametrize("ratio,ok", [(1.013, False), (0.86, False), (1.36, False), (1.37, True), (1.72, True),
                                      (2.44, True), (2.45, False)])
def test_b_worse_than_a_is_judged_on_the_excess(ratio, ok):
    """Published 0.761 / 0.442 = 1.722: B 72 % worse than A; within a factor two means 36-144 % worse."""
    assert checks_lab.excess_within_factor(ratio, 0.761 / 0.442) is ok


def test_yaw_ordering_is_our_own_and_claims_no_published_figure(two_node_orderings):
    med = lambda key: checks_lab.median("two_nodes_0p8hz", key)  # noqa: E731
    yaw = two_node_orderings["lab ordering: RMS yaw error node B / node A (hop count), ours only"]
    assert yaw.kind == "self_consistency" and math.isnan(yaw.published)
    assert yaw.ours == pytest.approx(med("node2_rms_yaw_error_deg") / med("node1_rms_yaw_error_deg"))
    assert yaw.ok == (yaw.ours > 1.0)


def test_counts_by_kind():
    rows = [within_factor("a", "s", 1.0, 1.0, 2.0), within_factor("b", "s", 9.0, 1.0, 2.0),
            within_factor("c", "s", 1.0, 1.0, 2.0, kind="hypothesis")]
    assert counts_by_kind(rows) == {"reproduction": (1, 2), "self_consistency": (0, 0), "hypothesis": (1, 1)}
    assert tuple(counts_by_kind(rows)) == KINDS
    with pytest.raises(ValueError):
        Check("d", "s", 1.0, 1.0, "rel 1", True, kind="reproduced")
