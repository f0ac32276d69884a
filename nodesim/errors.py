"""The one exception type for errors a user can cause.

Bad scenario files, bad logs, impossible physics: every such error raises :class:`NodesimError` with a
message naming the offending file/key/row and the allowed range.  The CLI prints the message without a
traceback and exits with status 2.
"""


from channel.errors import ChannelError
from firmware_model.errors import FirmwareError


class NodesimError(Exception):
    """A user-caused error (bad input, impossible physics).  ``str(err)`` is the full user message."""


class ScenarioError(NodesimError):
    """A scenario file that cannot be loaded or does not validate."""


USER_ERRORS = (NodesimError, ChannelError, FirmwareError)
"""Every user-caused error type of the three packages; the CLI turns each into one line and exit 2."""
