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
    bound = 8 * np.finfo(float).eps * np.abs(truth._sum_a).max()
    assert np.abs(gz - np.add.reduceat(u_gz, starts)).max() <= 8 * np.finfo(float).eps * np.abs(truth._sum_gz).max()
    assert np.abs(a - np.add.reduceat(u_a, starts, axis=0)).max() <= bound
    assert bound < 1e-4  # LSB: far below the count's rounding


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
