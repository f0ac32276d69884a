"""The chain IMU's compiled pieces agree with their plain numpy forms."""

import gc
import math
import weakref

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nodesim.chain import network
from nodesim.motion.chain_motion import build_motion
from nodesim.rng.streams import RunStreams
from nodesim.scenario.schema import Scenario
from nodesim.sensors import chain_imu, noise, sample_truth


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), K=st.integers(1, 60), sigma=st.floats(0.0, 50.0), tau_ticks=st.floats(0.5, 1e4))
def test_gauss_markov_kernel_is_the_numpy_recursion_bit_for_bit(seed, K, sigma, tau_ticks):
    """The fused drive (PCG64 normals drawn in the kernel) equals noise.gauss_markov_from_normals on the same
    stream's normals, along the ticks, for every axis; sigma = 0 draws nothing."""
    streams = RunStreams(seed=seed, n_nodes=1)
    state = streams.sensor_states(1, 0, "gyro_bias")
    phi = math.exp(-1.0 / tau_ticks)
    got = chain_imu._gauss_markov_bias(state[0].copy(), sigma, sigma * math.sqrt(1.0 - phi * phi), phi, np.zeros(3), True,
                                       K)
    if sigma == 0.0:
        assert not got.any()
        return
    w = streams.sensor_normals(1, 0, "gyro_bias", 3 * K).reshape(K, 3)
    want = noise.gauss_markov_from_normals(w, sigma, tau_ticks, 1.0, axis=0)
    assert np.array_equal(got, want)


def test_prefix_sum_tick_sums_match_direct_sums():
    """SampleTruth.tick_sums (prefix-sum differences) equals np.add.reduceat over each tick's samples to a few ulp
    of the running sum, on an hour of the lab profile."""
    scenario = Scenario.model_validate({"chain": {"nodes": 2}, "simulation": {"duration_s": 3600.0}})
    imu = chain_imu.ChainImu.from_scenario(scenario)
    motion = build_motion(scenario)
    t = np.arange(1, 6000) / 1.9
    first, n = chain_imu.tc.sample_windows(t, 1 / 1.9, imu.sample_rate_hz)
    truth = sample_truth.SampleTruth(imu, motion, int(first[0]) - 7, int(first[-1] + n[-1]) + 3)
    gz, a = truth.tick_sums(first, n)
    u_gz, u_a = truth.slice(int(first[0]), int(first[-1] + n[-1]))
    starts = first - first[0]
    bound = 8 * np.finfo(float).eps * np.abs(truth._sums[:, 1:]).max()
    assert np.abs(gz - np.add.reduceat(u_gz, starts)).max() <= 8 * np.finfo(float).eps * np.abs(truth._sums[:, 0]).max()
    assert np.abs(a - np.add.reduceat(u_a, starts, axis=0)).max() <= bound
    assert bound < 1e-4  # LSB: far below the count's rounding


def test_a_truth_without_its_readings_computes_the_same_readings_again():
    """A shared truth that keeps only its prefix sums (``keep_readings=False``: the tick-sum run's) gives the
    readings of any range of samples computed again, equal to the kept ones, and the same tick sums and maxima."""
    scenario = Scenario.model_validate({"chain": {"nodes": 2}, "simulation": {"duration_s": 1200.0}})
    imu = chain_imu.ChainImu.from_scenario(scenario)
    motion = build_motion(scenario)
    j_hi = int(1200 * imu.sample_rate_hz)
    kept = sample_truth.SampleTruth(imu, motion, -34, j_hi, shared=True)
    lean = sample_truth.SampleTruth(imu, motion, -34, j_hi, shared=True, keep_readings=False)
    assert lean.u_gz is None and lean.u_a is None
    rng = np.random.default_rng(3)
    for _ in range(12):
        a = int(rng.integers(-34, j_hi - 1))
        b = int(rng.integers(a + 1, min(j_hi, a + 20_000) + 1))
        for x, y in zip(kept.slice(a, b), lean.slice(a, b)):
            assert np.array_equal(x, y)
    t = np.arange(1, 2000) / 1.9
    first, n = chain_imu.tc.sample_windows(t, 1 / 1.9, imu.sample_rate_hz)
    for x, y in zip(kept.tick_sums(first, n), lean.tick_sums(first, n)):
        assert np.array_equal(x, y)
    assert all(np.array_equal(x, y) for x, y in zip(kept.umax, lean.umax))


def test_the_truth_does_not_depend_on_the_block_it_is_computed_in(monkeypatch):
    """SampleTruth computes its samples block by block, carrying the prefix sums and maxima: any block size (one
    sample, a few, one block for the whole range) gives the same sums, readings and maxima, bit for bit."""
    scenario = Scenario.model_validate({"chain": {"nodes": 2}, "simulation": {"duration_s": 1200.0}})
    imu = chain_imu.ChainImu.from_scenario(scenario)
    motion = build_motion(scenario)
    j_hi = int(300 * imu.sample_rate_hz)  # the profile's first 300 s: its spin-up ramps and first turns
    built = []
    for block in (1, 7, 1000, 1 << 20):
        monkeypatch.setattr(sample_truth, "TRUTH_BLOCK_SAMPLES", block)
        built.append(sample_truth.SampleTruth(imu, motion, -34, j_hi, shared=True))
    for other in built[1:]:
        assert np.array_equal(other._sums, built[0]._sums)
        assert np.array_equal(other.u_gz, built[0].u_gz) and np.array_equal(other.u_a, built[0].u_a)
        assert all(np.array_equal(x, y) for x, y in zip(other.umax, built[0].umax))


def test_node_counts_falling_back_per_sample_read_the_truth_s_readings_again_the_same():
    """Near the gyro's full scale (250 deg/s, turning at 249) ticks fall back to per-sample sums, which read the
    truth's readings: from a truth that kept them or one that computes them again, the same counts."""
    scenario = Scenario.model_validate({"chain": {"nodes": 2}, "simulation": {"duration_s": 400.0, "realizations": 2},
                                        "motion": {"fast_rate_deg_s": 249.0, "fast_turns": 10.0},
                                        "metrics": {"window_start_s": 300.0, "window_end_s": 400.0}})
    imu = chain_imu.ChainImu.from_scenario(scenario)
    motion = build_motion(scenario)
    t = np.arange(1, 750) / 1.9 + 0.013
    j_hi = int(400 * imu.sample_rate_hz) + 1
    out = []
    for keep in (True, False):
        truth = sample_truth.SampleTruth(imu, motion, -34, j_hi, shared=True, keep_readings=keep)
        out.append(chain_imu.node_counts(imu, motion, RunStreams(seed=9, n_nodes=2), 1, t, 1 / 1.9, 2, truth))
    assert out[0].per_sample_ticks > 0  # it did fall back
    for name in ("gyro_counts", "accel_counts", "gyro_clipped_samples", "true_bias_rad_s"):
        assert np.array_equal(getattr(out[0], name), getattr(out[1], name))


def test_a_finished_run_frees_its_network_without_the_cyclic_collector():
    """Nodes refer to their network weakly: once a run returns, its network (and every R-sized array only it
    held) goes when its last reference does, not at the next cyclic collection."""
    nets = []
    init = network.Network.__init__

    def spy(self, *a, **k):
        init(self, *a, **k)
        nets.append(weakref.ref(self))

    scenario = Scenario.model_validate({"chain": {"nodes": 3}, "simulation": {"duration_s": 60.0, "realizations": 2},
                                        "metrics": {"window_start_s": 0.0, "window_end_s": 60.0}})
    network.Network.__init__ = spy
    gc.disable()
    try:
        run = network.simulate_chain(scenario)
        assert nets and nets[0]() is None, "the network outlived the run"
        assert run.nodes[0].yaw_est_rad.shape[0] == 2
    finally:
        gc.enable()
        network.Network.__init__ = init


def _windows_equal_one_window(scenario_keys: dict, t: np.ndarray, shared: bool, cuts: list[int]) -> int:
    """A node's counts read window by window (:class:`chain_imu.NodeImuStream`, windows cut at ``cuts``) equal, tick
    for tick, its counts read in one window (:func:`chain_imu.node_counts`); returns the per-sample ticks."""
    scenario = Scenario.model_validate(scenario_keys)
    imu = chain_imu.ChainImu.from_scenario(scenario)
    motion = build_motion(scenario)
    R, dt = scenario.simulation.realizations, 1 / 1.9
    j_hi = int(scenario.simulation.duration_s * imu.sample_rate_hz) + 1
    truth = sample_truth.SampleTruth(imu, motion, -34, j_hi, shared=True) if shared else None
    whole = chain_imu.node_counts(imu, motion, RunStreams(seed=5, n_nodes=2), 1, t, dt, R, truth)
    stream = chain_imu.NodeImuStream(imu, motion, RunStreams(seed=5, n_nodes=2), 1, t, dt, R, truth)
    edges = [0, *cuts, t.size]
    parts = [stream.counts(a, b, truth) for a, b in zip(edges[:-1], edges[1:])]
    for name, axis in (("gyro_counts", 1), ("accel_counts", 1), ("samples", 0), ("true_bias_rad_s", 1)):
        assert np.array_equal(np.concatenate([getattr(p, name) for p in parts], axis=axis), getattr(whole, name)), name
    for name in ("gyro_clipped_samples", "accel_clipped_samples"):
        assert np.array_equal(sum(getattr(p, name) for p in parts), getattr(whole, name)), name
    assert sum(p.per_sample_ticks for p in parts) == whole.per_sample_ticks
    assert all(np.array_equal(p.tilt_rad, whole.tilt_rad) for p in parts)
    return whole.per_sample_ticks


def test_a_node_read_in_windows_of_ticks_reads_what_it_reads_at_once():
    """Tick sums drawn directly (the Gauss-Markov drive and the tick-sum normals, each in its stream, carried over
    each cut), from the shared truth or from the node's own truth continued window to window; windows of one
    tick, uneven ones, and a cut right after the first tick."""
    keys = {"chain": {"nodes": 2}, "simulation": {"duration_s": 600.0, "realizations": 3},
            "metrics": {"window_start_s": 0.0, "window_end_s": 600.0}}
    t = np.arange(1, 1100) / 1.9 + 0.013
    for shared in (True, False):
        for cuts in ([1], [1, 2, 3, 500, 501, 1097], [137, 700]):
            assert _windows_equal_one_window(keys, t, shared, cuts) == 0
    keys["sensor"] = {"gyro_bias_instability_deg_s": 0.0}  # no drive: its stream is not drawn from
    assert _windows_equal_one_window(keys, t, True, [1, 600]) == 0


def test_windows_of_ticks_fall_back_per_sample_as_at_once():
    """Near the gyro's full scale (250 deg/s, turning at 249) the same ticks fall back to per-sample sums, with the
    same normals (each realization's per-sample stream goes on from window to window), and ``per_sample`` sampling
    reads every tick per sample the same in windows."""
    keys = {"chain": {"nodes": 2}, "simulation": {"duration_s": 400.0, "realizations": 2},
            "motion": {"fast_rate_deg_s": 249.0, "fast_turns": 10.0},
            "metrics": {"window_start_s": 300.0, "window_end_s": 400.0}}
    t = np.arange(1, 750) / 1.9 + 0.013
    assert _windows_equal_one_window(keys, t, True, [100, 333, 334, 600]) > 0
    keys["sensor"] = {"sampling": "per_sample"}
    assert _windows_equal_one_window(keys, t[:300], True, [17, 150]) == 2 * 2 * 300


def test_windows_must_follow_each_other():
    scenario = Scenario.model_validate({"chain": {"nodes": 2}})
    imu = chain_imu.ChainImu.from_scenario(scenario)
    t = np.arange(1, 50) / 1.9
    stream = chain_imu.NodeImuStream(imu, build_motion(scenario), RunStreams(seed=5, n_nodes=2), 1, t, 1 / 1.9, 1)
    stream.counts(0, 10)
    with pytest.raises(ValueError, match=r"ticks \[11, 20\) do not follow tick 10"):
        stream.counts(11, 20)


def test_a_truth_continued_from_another_sums_as_one_truth_over_both():
    """``start_sums``: a truth over [b, c) continuing one over [a, b) has the prefix sums of one truth over [a, c),
    bit for bit (without them it would restart at 0, and its tick sums would differ in their last bits)."""
    scenario = Scenario.model_validate({"chain": {"nodes": 2}, "simulation": {"duration_s": 600.0}})
    imu = chain_imu.ChainImu.from_scenario(scenario)
    motion = build_motion(scenario)
    a, b, c = -34, 20_011, 38_000
    one = sample_truth.SampleTruth(imu, motion, a, c, 1)
    head = sample_truth.SampleTruth(imu, motion, a, b, 1)
    tail = sample_truth.SampleTruth(imu, motion, b, c, 1, start_sums=head.end_sums)
    assert np.array_equal(np.concatenate([head._sums[:-1], tail._sums]), one._sums)
    restarted = sample_truth.SampleTruth(imu, motion, b, c, 1)
    assert not np.array_equal(restarted._sums[1:] + head.end_sums, one._sums[b - a + 1:])


@pytest.mark.parametrize("seed", range(6))
def test_the_window_check_of_the_direct_draws_marks_the_ticks_the_tick_by_tick_check_marks(seed):
    """_direct_invalid's shortcut (every tick valid when the window's largest bounds are) sets the same ticks as the
    tick-by-tick check, on windows all valid, with a few ticks near full scale, with NaNs and without ticks."""
    rng = np.random.default_rng(seed)
    K = 500
    T = chain_imu.tilt_matrices(rng.normal(scale=0.02, size=(1, 2)))[0]
    g_lo, g_hi, a_lo, a_hi = -32768 * 34, 32767 * 34, -32768 * 34, 32767 * 34
    cases = []
    for near in (False, True):
        umax_gz, umax_a = rng.uniform(0, 2e5, K), rng.uniform(0, 3e5, (K, 3))
        gm = rng.normal(scale=50.0, size=(K, 3))
        if near:  # a few ticks (and the bias of one) at full scale
            umax_gz[rng.integers(0, K, 3)] = 1.02 * g_hi
            umax_a[rng.integers(0, K, 2), rng.integers(0, 3)] = 1.02 * a_hi
            gm[rng.integers(0, K), 1] = 2e6
        cases.append((umax_gz, umax_a, gm))
    nan_gm = cases[0][2].copy()
    nan_gm[7, 2] = np.nan
    cases += [(cases[0][0], cases[0][1], nan_gm), (np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)))]
    marked = []
    for umax_gz, umax_a, gm in cases:
        args = (umax_gz, umax_a, T, 1.001, 40.0, -3.0, gm, 3.0, 5.0, g_lo, g_hi, a_lo, a_hi)
        got = (np.ones(gm.shape[0], bool), np.ones(gm.shape[0], bool))
        want = (np.zeros(gm.shape[0], bool), np.zeros(gm.shape[0], bool))
        chain_imu._direct_invalid(*args, *got)
        chain_imu._direct_invalid_ticks(*args, *want)
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
        marked.append((int(want[0].sum()), int(want[1].sum())))
    assert marked[0] == (0, 0) and 0 < marked[1][0] < K and 0 < marked[1][1] < K, marked  # all valid; some ticks each
    assert chain_imu._window_valid(*cases[0][:2], T, 1.001, 40.0, -3.0, cases[0][2], 3.0, 5.0, g_lo, g_hi, a_lo, a_hi)
    assert not chain_imu._window_valid(*cases[1][:2], T, 1.001, 40.0, -3.0, cases[1][2], 3.0, 5.0, g_lo, g_hi, a_lo,
                                       a_hi)
