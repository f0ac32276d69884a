"""The C reference firmware (firmware_model/c/node_firmware.c) against the model on the node streams the chain
really feeds it (issue 19, must-show): every bundled lab scenario, every node, 4 realizations, the whole run.
The SimPy engine's firmware calls (nodesim.chain.estimator.FirmwareLanes.tick) are recorded - inputs and the
state after each tick - and every lane's input stream is replayed through the C node_firmware_run from a fresh
lane; each state word after each tick, each output and the overflow counters must be identical.  The survey
(firmware_model/c/survey.c survey_run: mid-window yaw, alignment offset over the slow rotation, resolution, moving
average) is run in C on each lane's accelerometer count sums and yaw words and must give the I and A words the run
reported."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from firmware_model import c_reference
from firmware_model import node_firmware as nf
from firmware_model import node_survey as survey
from nodesim.api import simulate
from firmware_model.yaw_filter import B_TUNINGS
from nodesim.chain.estimator import FirmwareLanes, alignment_ticks, alignment_window_s, yaw_rad_of_raw
from nodesim.scenario.schema import FilterSection

ROOT = Path(__file__).resolve().parents[3]
LAB = sorted((ROOT / "scenarios" / "lab").glob("*.toml"))


@pytest.fixture
def traced(monkeypatch):
    """Every FirmwareLanes of the run -> list of (inputs (R, 8), states after (R, 11), outputs (R, 4)) per tick."""
    calls: dict[int, tuple[FirmwareLanes, list]] = {}
    original = FirmwareLanes.tick

    def tick(self, *args, **kwargs):
        out = original(self, *args, **kwargs)
        calls.setdefault(id(self), (self, []))[1].append((self.inputs.copy(), self.states.copy(), out.copy()))
        return out

    monkeypatch.setattr(FirmwareLanes, "tick", tick)
    return calls


# every lab scenario under the default filter.b_tuning, and the continuous one under the other reading of B
OTHER_B_TUNING = next(b for b in B_TUNINGS if b != FilterSection.model_fields["b_tuning"].default)
CASES = [(p, None) for p in LAB] + [(ROOT / "scenarios" / "lab" / "continuous.toml", OTHER_B_TUNING)]


@pytest.mark.parametrize("path,b_tuning", CASES, ids=[p.stem + (f"-{b}" if b else "") for p, b in CASES])
def test_c_reference_equals_the_model_on_every_lab_node_stream(path, b_tuning, traced):
    # the alignment offset forced on (the default sensor has no tilt, so "auto" would leave it out)
    over = {"filter.b_tuning": b_tuning} if b_tuning else {}
    run = simulate(path, realizations=4, **{"filter.implementation": "fixed", "simulation.engine": "event",
                                            "firmware.alignment": "slow_rotation", **over})
    if b_tuning:
        assert run.scenario.filter.b_tuning == b_tuning
    ffi, lib = c_reference.load()
    buf = lambda a: ffi.from_buffer("int64_t[]", a)  # noqa: E731
    assert len(traced) == len(run.chain.nodes) >= 1
    for (fw, ticks), node in zip(traced.values(), run.chain.nodes):
        assert fw.config.filter.b_tuning == run.scenario.filter.b_tuning  # the reading reached the firmware build
        inputs = np.stack([t[0] for t in ticks], 1)  # (R, K, 8)
        states = np.stack([t[1] for t in ticks], 1)  # (R, K, 11)
        outputs = np.stack([t[2] for t in ticks], 1)
        R, K = inputs.shape[:2]
        assert R == 4 and K > 1000
        counts_c = np.zeros(len(nf.SITES), np.int64)
        for r in range(R):
            st = np.zeros(nf.STATE_SIZE, np.int64)
            lib.nf_init_lane(buf(st))
            x = np.ascontiguousarray(inputs[r])
            out_c, hist_c = np.zeros((K, len(nf.OUTPUTS)), np.int64), np.zeros((K, nf.STATE_SIZE), np.int64)
            lib.node_firmware_run(buf(st), buf(fw.params), buf(fw.fparams), buf(counts_c), buf(x), buf(out_c),
                                  buf(hist_c), K)
            bad = np.flatnonzero((hist_c != states[r]).any(1) | (out_c != outputs[r]).any(1))
            assert bad.size == 0, f"node {node.node_id} lane {r}: first differing tick {bad[0]}"
        np.testing.assert_array_equal(counts_c, fw.counts)
        # the recorded stream is what the run reported: its last yaw is the traced state's
        np.testing.assert_array_equal(yaw_rad_of_raw(states[:, -1, 0], fw.fparams), node.yaw_est_rad[:, -1])
        assert (inputs[:, :, nf.IN_REF] != nf.NO_REF).any(), "the stream exercises updates"
        _survey_in_c(ffi, lib, buf, fw.config, run.scenario, node)


def _survey_in_c(ffi, lib, buf, cfg, scenario, node):
    """The C survey over the node's lanes: the I and A words the run reported (floats of exact binary angles)."""
    first = int(np.searchsorted(node.t_s, node.present_from_s))
    lo, hi = alignment_ticks(alignment_window_s(scenario), node.t_s[first:])
    assert hi - lo > 300  # the lab profile's slow rotation is the alignment window
    K, points = node.t_s.size - first, cfg.survey_points
    samples = np.ascontiguousarray(node.samples[first:])
    for r in range(node.yaw_est_rad.shape[0]):
        yaw = np.ascontiguousarray(cfg.encoder_yaw_raw(node.yaw_est_rad[r, first:]))  # the yaw words, exactly
        accel = np.ascontiguousarray(node.accel_counts[r, first:])
        state, inc, azi = np.zeros(survey.ma_state_size(points), np.int64), np.zeros(K, np.int64), np.zeros(K, np.int64)
        assert lib.survey_run(buf(accel), buf(yaw), buf(samples), K, lo, hi, points, cfg.survey_mode,
                              cfg.cordic_iterations, cfg.formats.yaw.frac_bits, buf(state), buf(inc), buf(azi)) == 0
        assert state[survey.AL_PHASE] == survey.ALIGN_APPLIED
        np.testing.assert_array_equal(survey.inclination_rad(inc), node.inclination_rad[r, first:])
        np.testing.assert_array_equal(survey.azimuth_rad(azi), node.azimuth_rad[r, first:])
