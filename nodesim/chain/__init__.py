"""The chain simulation core: encoder, sensor nodes, simple links and the ground-station sink (SimPy).

``simulate_chain(scenario) -> ChainRun``; metrics in :mod:`nodesim.chain.metrics`, run-directory files in
:mod:`nodesim.chain.outputs`.
"""

from nodesim.chain.network import ChainRun, NodeRun, simulate_chain

__all__ = ["ChainRun", "NodeRun", "simulate_chain"]
