"""Compiled (numba) chain engine, bit-identical to the SimPy engine it replaces for speed.

:mod:`.engine` runs a built network in two phases: :mod:`.events` (every tick, frame and packet in SimPy's
order, with :mod:`.mac_kernel`) and :mod:`.filters` (each node's filter down the chain: :mod:`.float_kernel`
for the float reference, or the fixed-point node firmware itself, :func:`firmware_model.node_firmware.node_tick`,
the njit code the SimPy engine and the replay call too).
"""
