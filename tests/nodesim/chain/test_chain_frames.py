"""Estimate frames in the chain: both engines send the bytes of :mod:`firmware_model.frames` and the receivers
decode them (issue 19, item 3); the frames a node sent are part of its records."""

import numpy as np
import pytest

from firmware_model import frames as fr
from nodesim.chain.network import simulate_chain
from nodesim.scenario.schema import Scenario

LOSSY_FIXED = {
    "chain.nodes": 4, "simulation.duration_s": 160.0, "simulation.realizations": 3,
    "metrics.window_start_s": 60.0, "metrics.window_end_s": 160.0, "radio.model": "channel",
    "radio.shadowing_sigma_db": 0.0, "radio.soil.distance_m": 2.0, "radio.soil.vwc": 0.275, "mac.enabled": True,
    "filter.implementation": "fixed",
}


@pytest.mark.parametrize("engine", ["event", "compiled"])
def test_the_sent_frames_carry_the_senders_words_and_the_receivers_use_them(engine):
    run = simulate_chain(Scenario().with_overrides(**{**LOSSY_FIXED, "simulation.engine": engine}))
    for n in run.nodes[:-1]:
        f = n.estimate_frames
        sent = f[:, :, 0] == fr.ESTIMATE
        assert sent.sum() > 50 and not f[:, :, 0][~sent].any()
        values, ok = fr.decode(fr.ESTIMATE, f[sent])
        assert ok.all()
        r, k = np.nonzero(sent)
        assert (values[:, fr.field_index(fr.ESTIMATE, "node")] == n.node_id).all()
        assert (values[:, fr.field_index(fr.ESTIMATE, "seq")] == k).all()  # the sender's tick counter
        assert (values[:, fr.field_index(fr.ESTIMATE, "t_read_us")] == np.rint(n.t_s[k] * 1e6)).all()
        assert np.array_equal(n.update_mask[sent], np.ones(sent.sum(), bool))  # sent where it applied an update
    assert not run.nodes[-1].estimate_frames.any()  # the bottom node sends none
