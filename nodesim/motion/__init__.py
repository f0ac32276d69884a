"""Motion: the true movement of the drill string and of every node on it.

Modules: :mod:`~nodesim.motion.rotation` (the thesis lab rotation profile and piecewise rate profiles),
:mod:`~nodesim.motion.drilling` (a wellpath and the drilling process: tube insertions, true attitude of every
node), :mod:`~nodesim.motion.timelines` (what the chain needs: per-node timelines, survey stops, attitudes),
:mod:`~nodesim.motion.drilling_timelines` (the drilling process as per-node timelines) and
:mod:`~nodesim.motion.chain_motion` (a scenario's motion, lab or drilling).
"""
