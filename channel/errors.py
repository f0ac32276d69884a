"""The error type of the channel package: bad physical input (negative distance, fractions outside [0, 1], ...).

It subclasses ValueError; the ``nodesim`` CLI treats it like :class:`nodesim.errors.NodesimError` (one line,
exit status 2).  ``channel`` cannot import ``nodesim``, hence its own type.
"""


class ChannelError(ValueError):
    """Impossible or out-of-range channel input; the message names the parameter and the allowed range."""
