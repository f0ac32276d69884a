"""The compiled SeedSequence hash (nodesim.rng.streams.seed_states) against numpy's own, bit for bit."""

import numpy as np
import pytest

from nodesim.rng import pcg64
from nodesim.rng.streams import VECTOR_MIN_KEYS, RunStreams, generators, seed_states


def _numpy_states(seed, keys):
    return np.array([np.random.SeedSequence(seed, spawn_key=tuple(int(x) for x in k)).generate_state(4, np.uint64)
                     for k in keys])


@pytest.mark.parametrize("seed", [0, 1, 12345, 2**32 - 1, 2**32, 2**40 + 7, 2**63 - 1])
@pytest.mark.parametrize("width", [1, 2, 3, 5])
def test_seed_states_equal_numpy(seed, width):
    keys = np.random.default_rng(width).integers(0, 2**32, size=(40, width))
    keys[0], keys[1] = 0, 2**32 - 1  # the word edges
    assert (seed_states(seed, keys) == _numpy_states(seed, keys)).all()


@pytest.mark.parametrize("m", [1, VECTOR_MIN_KEYS - 1, VECTOR_MIN_KEYS, 100])
def test_generators_draw_what_default_rng_draws(m):
    keys = np.column_stack([np.arange(m), np.full(m, 7)])
    ours = generators(3, keys)
    ref = [np.random.default_rng(np.random.SeedSequence(3, spawn_key=(r, 7))) for r in range(m)]
    for a, b in zip(ours, ref):
        assert (a.standard_normal(50) == b.standard_normal(50)).all()


@pytest.mark.parametrize("bad", [np.array([[-1, 0]]), np.array([[2**32, 0]]), np.array([1, 2])])
def test_seed_states_reject_bad_keys(bad):
    with pytest.raises(ValueError, match="spawn keys"):
        seed_states(0, bad)


def test_batch_methods_equal_one_by_one():
    s = RunStreams(seed=11, n_nodes=4, first_realization=5)
    R = 40
    pairs = [(s.link_batch(R, 3), [s.link(r, 3) for r in range(R)]),
             (s.radio_batch(R, 1), [s.radio(r, 1) for r in range(R)]),
             (s.skip_link_batch(R, 2), [s.skip_link(r, 2) for r in range(R)])]
    for batch, single in pairs:
        for a, b in zip(batch, single):
            assert (a.random(8) == b.random(8)).all()


@pytest.mark.parametrize("R", [1, VECTOR_MIN_KEYS + 3])
def test_compiled_draws_equal_the_streams_one_by_one(R):
    """sensor_normals / link_states (nodesim.rng.pcg64) give each realization's stream's own numbers."""
    s = RunStreams(seed=11, n_nodes=4, first_realization=5)
    normals = s.sensor_normals(R, 2, "accel", 300)
    for r in range(R):
        assert (normals[r] == s.sensor(r, 2, "accel").standard_normal(300)).all()
    for states, one in ((s.link_states(R, 3), lambda r: s.link(r, 3)), (s.skip_link_states(R, 2),
                                                                         lambda r: s.skip_link(r, 2))):
        buf = np.empty(R * 8)
        pcg64.fill_uniforms(states, np.arange(R), buf, np.arange(R) * 8, np.arange(R) * 8 + 8)
        for r in range(R):
            assert (buf[8 * r:8 * r + 8] == one(r).random(8)).all()
