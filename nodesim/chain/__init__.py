"""The chain network: encoder, sensor nodes, radio hops, MAC, faults and the ground-station sink.

:func:`nodesim.chain.network.simulate_chain` runs a scenario's chain and returns a
:class:`~nodesim.chain.network.ChainRun`: the SimPy engine (:mod:`.network`, :mod:`.node_process`) is the
readable reference, :mod:`.compiled` the fast twin with the same numbers.  Metrics in
:mod:`.metrics` and :mod:`.linkmetrics`; a run's tables in :mod:`.run_tables`, its yaw plot in
:mod:`.yaw_plot`.
"""
