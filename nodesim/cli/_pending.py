"""Shared behaviour of sub-commands whose implementation has not landed yet.

A pending command already declares its documented options (so ``--help`` describes them), then says it is
not implemented yet and exits with status 2.
"""

from __future__ import annotations

from typing import Callable

from nodesim.errors import NodesimError


def register_pending(sub, name: str, help_text: str, what: str, add_arguments: Callable) -> None:
    """Add parser ``name`` with its future options; running it raises a clear 'not implemented' error."""
    p = sub.add_parser(name, help=f"{help_text} (not implemented yet)", description=f"{help_text}. Not implemented yet: {what}.")
    add_arguments(p)

    def run(_args) -> int:
        raise NodesimError(f"'nodesim {name}' is not implemented yet ({what})")

    p.set_defaults(func=run)
