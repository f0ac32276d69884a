"""The chain's fixed-point 6-state node (issue 24, ``filter.states = 6``, ``filter.implementation = "fixed"``): the
node firmware of :mod:`firmware_model.six_state_firmware` in every realization, with the interface of the 2-state
:class:`nodesim.chain.estimator.FirmwareLanes`, so both chain engines treat it as they treat the 2-state firmware.

It reads the same words in the same slots (the twist as the yaw word, h P h^T as the P_yy word, the z bias, the
running flag: :mod:`firmware_model.six_state_firmware`'s state layout), takes the 2-state firmware's inputs plus the
tick's x, y gyro sums and x, y, z accelerometer sums (:meth:`read_sensors`), and names its overflow sites :data:`firmware_model.six_state_firmware.SITES`
(the 6-state filter's prefixed "6-state ").  The SimPy engine drives it tick by tick (:meth:`tick`); the compiled
engine runs the same njit tick in :func:`nodesim.chain.compiled.filters.run_node_firmware`.
"""

from __future__ import annotations

import numpy as np

from firmware_model import node_firmware as nf
from firmware_model import six_state_kernel as k6
from firmware_model import six_state_firmware as n6
from nodesim.chain.estimator import FirmwareLanes, firmware_config, six_state_firmware_config, six_state_params
from nodesim.scenario.schema import Scenario


class SixStateFirmwareLanes(FirmwareLanes):
    """One fixed-point 6-state node in every realization (module docstring); ``singular_ticks`` (R,) the ticks its
    filter's pitch spent inside the singularity margin."""

    SITES = n6.SITES
    INPUTS = n6.INPUTS
    STATE_SIZE = n6.STATE_SIZE
    init_lane = staticmethod(n6.init_lane)

    def __init__(self, scenario: Scenario, realizations: int):
        firmware, build6 = six_state_firmware_config(scenario)
        super().__init__(firmware, realizations)
        params6, lane0 = six_state_params(build6)
        self.params6, self.lane0 = params6.copy(), lane0.copy()
        self.work = np.zeros(k6.WORK_SIZE, dtype=np.int64)

    def __repr__(self) -> str:
        return (f"SixStateFirmwareLanes(realizations={self.states.shape[0]}, overflows={self.overflow_counts}, "
                f"singular_ticks={int(self.singular_ticks.sum())})")

    def read_sensors(self, sig, k: int) -> None:
        """The tick's x, y gyro sums and accelerometer sums into the inputs (``sig`` the node's NodeSignals)."""
        self.inputs[:, n6.IN_GX:n6.IN_GX + 2] = sig.gyro_counts[:, k, :2]
        self.inputs[:, n6.IN_AX:n6.IN_AX + 3] = sig.accel_counts[:, k]

    def _step(self) -> None:
        n6.node_tick_lanes(self.states, self.params6, self.lane0, self.params, self.fparams, self.counts,
                           self.inputs, self.outputs, self.work)

    @property
    def singular_ticks(self) -> np.ndarray:
        return self.states[:, n6.O6 + k6.I_SING].copy()

    @property
    def levelled_ticks(self) -> np.ndarray:
        """(R,) the ticks the filter was levelled (static, ``filter.levelling = "static"``)."""
        return self.states[:, n6.S_LEVELLED].copy()


def firmware_lanes(scenario: Scenario, realizations: int) -> FirmwareLanes:
    """The fixed-point node firmware a node of ``scenario`` runs: 2-state or 6-state (``filter.states``)."""
    if scenario.filter.states == 6:
        return SixStateFirmwareLanes(scenario, realizations)
    return FirmwareLanes(firmware_config(scenario), realizations)
