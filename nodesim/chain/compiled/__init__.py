"""Compiled (numba) kernels of the chain engine, bit-identical to the numpy/SimPy code they replace.

:mod:`nodesim.chain.compiled.fixed_kernel`: the fixed-point yaw filter of
:class:`firmware_model.fixed_filter.FixedYawFilter` as scalar ``@njit`` functions on one realization.
``firmware_model`` stays pure numpy; numba lives here, in the composition layer.
"""
