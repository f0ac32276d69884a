"""The compiled PCG64 draws (nodesim.rng.pcg64) against numpy's Generator, bit for bit."""

import numpy as np
import pytest

from nodesim.rng import pcg64


def _streams(m, seed=2024):
    seqs = [np.random.SeedSequence(seed, spawn_key=(i, 9)) for i in range(m)]
    words = np.stack([s.generate_state(4, np.uint64) for s in seqs])
    return seqs, pcg64.seeded(words)


def test_seeding_gives_numpys_pcg64_state():
    seqs, states = _streams(50)
    for seq, st in zip(seqs, states):
        ref = np.random.PCG64(seq).state["state"]
        assert (int(st[0]) << 64 | int(st[1])) == ref["state"]
        assert (int(st[2]) << 64 | int(st[3])) == ref["inc"]


def test_standard_normals_equal_numpy_including_the_ziggurat_tail_and_wedges():
    # 40 x 20000 draws: ~3000 go through the wedge test and ~100 through the tail (|x| > 3.654)
    seqs, states = _streams(40)
    out = np.empty((40, 20000))
    pcg64.fill_normals(states, out)
    ref = np.stack([np.random.Generator(np.random.PCG64(s)).standard_normal(20000) for s in seqs])
    assert (np.abs(ref) > 3.6541528853610088).sum() > 50
    assert np.array_equal(out, ref)


@pytest.mark.parametrize("first", [0, 1, 777])
def test_uniforms_continue_the_stream(first):
    """Normals then uniforms in pieces: the state advances exactly as numpy's Generator does."""
    seqs, states = _streams(6)
    gens = [np.random.Generator(np.random.PCG64(s)) for s in seqs]
    head = np.empty((6, first))
    pcg64.fill_normals(states, head)
    for g, row in zip(gens, head):
        assert np.array_equal(g.standard_normal(first), row)
    rows = np.array([4, 0, 5])
    buf = np.zeros(40)
    pcg64.fill_uniforms(states, rows, buf, np.array([0, 10, 30]), np.array([10, 30, 35]))
    assert np.array_equal(buf[0:10], gens[4].random(10))
    assert np.array_equal(buf[10:30], gens[0].random(20))
    assert np.array_equal(buf[30:35], gens[5].random(5))
    assert (buf[35:] == 0).all()
