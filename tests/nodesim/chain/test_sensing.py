"""The sensor adapter (nodesim.chain.sensing): the float filter's readings from the count sums."""

import numpy as np


def test_the_counts_in_si_units_are_numpys_expressions_bit_for_bit():
    """The float filter's readings from the count sums (one compiled pass): numpy's two divisions, the same bits."""
    from nodesim.chain.sensing import _counts_to_si

    rng = np.random.default_rng(3)
    R, K = 3, 2000
    gyro, accel = rng.integers(-2**40, 2**40, (R, K, 3)), rng.integers(-2**40, 2**40, (R, K, 3))
    samples = rng.integers(30, 40, K)
    s_g, s_a = 131.0 * 180.0 / np.pi, 16384.0 / 9.80665
    n = samples.astype(float)
    out_g, out_f = np.empty((R, K)), np.empty((R, K, 3))
    _counts_to_si(gyro, accel, samples, s_g, s_a, out_g, out_f)
    assert out_g.tobytes() == (gyro[:, :, 2] / n / s_g).tobytes()
    assert out_f.tobytes() == (accel / n[None, :, None] / s_a).tobytes()
