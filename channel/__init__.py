"""channel: physics and statistics of the radio links (868 MHz through soil, 5 GHz in the pipe).

Pure, vectorised functions plus small frozen parameter objects.  No SimPy.  Randomness only through a
``numpy.random.Generator`` passed in.  Never imports ``nodesim`` or ``firmware_model``.

Modules: ``soil`` (Peplinski permittivity, alpha/beta, modified Friis loss, thesis eqs 5.1-5.3), ``waveguide``
(circular-waveguide cutoffs, modes and attenuation, eqs 5.4-5.8), ``steel`` (wall resistivity of API 5L carbon
steel), ``budget`` (link budget, shadowing, Gilbert-Elliott bursts), ``per`` (noise floor, BER, PER),
``constants``, ``errors``.
"""
