"""The chain IMU's compiled pieces agree with their plain numpy forms."""

import gc
import math
import weakref

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from nodesim.chain import network
from nodesim.motion.chain_motion import build_motion
from nodesim.rng.streams import RunStreams
from nodesim.scenario.schema import Scenario
from nodesim.sensors import chain_imu, noise


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), K=st.integers(1, 60), sigma=st.floats(0.0, 50.0), tau_ticks=st.floats(0.5, 1e4))
def test_gauss_markov_kernel_is_the_numpy_recursion_bit_for_bit(seed, K, sigma, tau_ticks):
    """The fused drive (PCG64 normals drawn in the kernel) equals noise.gauss_markov_from_normals on the same
    stream's normals, along the ticks, for every axis; sigma = 0 draws nothing."""
    streams = RunStreams(seed=seed, n_nodes=1)
    state = streams.sensor_states(1, 0, "gyro")
    phi = math.exp(-1.0 / tau_ticks)
    got = chain_imu._gauss_markov_bias(state[0].copy(), sigma, sigma * math.sqrt(1.0 - phi * phi), phi, K)
    if sigma == 0.0:
        assert not got.any()
        return
    w = streams.sensor_normals(1, 0, "gyro", 3 * K).reshape(K, 3)
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
    truth = chain_imu.SampleTruth(imu, motion, int(first[0]) - 7, int(first[-1] + n[-1]) + 3)
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
    kept = chain_imu.SampleTruth(imu, motion, -34, j_hi, shared=True)
    lean = chain_imu.SampleTruth(imu, motion, -34, j_hi, shared=True, keep_readings=False)
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
        monkeypatch.setattr(chain_imu, "TRUTH_BLOCK_SAMPLES", block)
        built.append(chain_imu.SampleTruth(imu, motion, -34, j_hi, shared=True))
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
        truth = chain_imu.SampleTruth(imu, motion, -34, j_hi, shared=True, keep_readings=keep)
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
