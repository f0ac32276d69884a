"""The error type of the firmware model: bad input to the firmware (NaN samples, non-monotonic time, ...).

It subclasses ValueError; the ``nodesim`` CLI treats it like :class:`nodesim.errors.NodesimError` (one line,
exit status 2).  ``firmware_model`` cannot import ``nodesim``, hence its own type.
"""


class FirmwareError(ValueError):
    """Input the firmware model rejects; the message names the input and what is allowed."""
