"""channel: physics and statistics of the radio links (868 MHz through soil, 5 GHz in the pipe).

Pure, vectorised functions plus small frozen parameter objects.  No SimPy.  Randomness only through a
``numpy.random.Generator`` passed in.  Never imports ``nodesim`` or ``firmware_model``.
"""
