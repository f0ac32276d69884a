"""Compiled (numba) chain engine, bit-identical to the SimPy engine it replaces for speed.

:mod:`.engine` runs a built network in two phases: :mod:`.events` (every tick, frame and packet in SimPy's
order, with :mod:`.mac_kernel`) and :mod:`.filters` (each node's filter down the chain, with
:mod:`.float_kernel` or :mod:`firmware_model.fixed_kernel`, the fixed-point yaw filter of
:class:`firmware_model.fixed_filter.FixedYawFilter` as scalar functions).  ``firmware_model`` stays pure numpy;
numba lives here, in the composition layer.
"""
