"""Arbitrary update schedules: windows of (start, stop, rate) and their use in the chain."""

import numpy as np

from nodesim.scenario.schedules import UpdateSchedule

DT = 1 / 1.9


def test_arbitrary_windows_update_at_their_rates_and_nowhere_else():
    t = np.arange(0, 300, DT)
    s = UpdateSchedule("arbitrary", windows=((10.0, 60.0, 100.0), (100.0, 200.0, 0.1)))
    m = s.mask(t, DT)
    first = (t + DT > 10.0) & (t < 60.0)
    assert m[first].all()  # rate above the tick rate: every tick
    assert not m[(t >= 60.0) & (t + DT <= 100.0)].any() and not m[t + DT <= 10.0].any()
    second = m[(t + DT > 100.0) & (t < 200.0)]
    assert second.sum() == 10  # 0.1 Hz for 100 s
    assert not m[t >= 200.0].any()


def test_windowed_is_an_arbitrary_schedule_with_repeated_windows():
    t = np.arange(0, 500, DT)
    windowed = UpdateSchedule("windowed", update_s=20, timeout_s=30).mask(t, DT)
    wins = tuple((50.0 * i, 50.0 * i + 20.0, 1e3) for i in range(10))
    arbitrary = UpdateSchedule("arbitrary", windows=wins).mask(t, DT)
    # the same except for ticks that straddle a window start (arbitrary takes the tick that overlaps it)
    assert (windowed <= arbitrary).all()
    assert (arbitrary & ~windowed).sum() <= len(wins)


def test_single_updates_at_the_thesis_frequencies():
    t = np.arange(0, 600, DT)
    for f in (0.2, 0.1, 0.05, 0.0167, 0.01):  # thesis digest 5.3 (iii)
        n = UpdateSchedule("single", single_rate_hz=f).mask(t, DT).sum()
        assert abs(n - 600 * f) <= 1
