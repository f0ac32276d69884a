"""Random streams: one root seed, SeedSequence children in a fixed order, numpy's PCG64 as compiled loops.

Modules: :mod:`~nodesim.rng.streams` (the stream order and the per-run generators) and
:mod:`~nodesim.rng.pcg64` (numpy's PCG64 ``random()`` / ``standard_normal()`` over many streams, bit for bit).
"""
