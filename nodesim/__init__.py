"""nodesim: simulator of a drill-string sensor chain.

Layers (one direction, top to bottom): kinematics -> sensors -> firmware_model -> channel/network
-> ground station -> results.  See README.md and the architecture note.
"""

from importlib.metadata import PackageNotFoundError, version

from nodesim.errors import NodesimError

try:
    __version__ = version("nodesim")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

__all__ = ["NodesimError", "__version__"]
