"""Phase 2 of the compiled engine for a fixed-point 6-state node (``filter.states = 6``, ``implementation =
"fixed"``): the node runs :func:`firmware_model.six_state_firmware.node_tick` inside the fixed firmware's loop
(:func:`.filters.run_node_firmware` with ``six``), its lanes and build those of
:class:`nodesim.chain.six_state_firmware_lanes.SixStateFirmwareLanes`, the object the SimPy engine drives; these are the
loop's 6-state arguments."""

from __future__ import annotations

import numpy as np

from nodesim.chain.six_state_firmware_lanes import SixStateFirmwareLanes

_NONE = np.zeros(1, dtype=np.int64)  # the 2-state firmware's stand-in for the 6-state build (never read)


def build(fw) -> tuple[bool, np.ndarray, np.ndarray]:
    """(six, params6, lane0) for :func:`.filters.run_node_firmware` from the node's firmware lanes ``fw``."""
    if isinstance(fw, SixStateFirmwareLanes):
        return True, fw.params6, fw.lane0
    return False, _NONE, _NONE
