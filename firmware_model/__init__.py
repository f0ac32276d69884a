"""firmware_model: what runs on the node MCU, as a model.

Pure computation on numpy arrays with a leading batch (realization) axis.  No SimPy, no file I/O, no
randomness: noise arrives with the sensor samples.  Never imports ``nodesim`` or ``channel``.
"""
