"""What the host can tell a user about HCTMPS1 commands (hctmps1.md §4), from the module
core's own command list: ``bus ask``'s hints, so the CLI needs no core."""

from __future__ import annotations

from sondalog.hctmps1 import COMMAND_NAMES, CONNECT_COMMANDS


def upper_case_hint(command: str) -> str | None:
    """The refusal of ``command`` written in lower case when its upper case is a command
    (a module ignores anything else), or ``None``."""
    if command != command.upper() and command.upper() in COMMAND_NAMES:
        return (
            f"{command!r}: HCTMPS1 commands are upper case, and a module ignores anything"
            f" else: {command.upper()}"
        )
    return None


def why_no_reply(module_id: str, command: str, host_id: str) -> str:
    """What a module that answers HELLO needs before it answers ``command`` (hctmps1.md §4)."""
    if command == "CONNECT":
        return (
            f"no reply from {module_id} to CONNECT: a wrong password gets none, and after 5"
            " wrong ones in 60 s the module ignores CONNECT for 60 s (factory password 0000)"
        )
    if command in CONNECT_COMMANDS:
        return (
            f"no reply from {module_id} to {command}: {command} is answered only inside"
            f" <connect>. Open it first with the same --host-id ({host_id}):"
            f" sondalog bus ask URL {module_id} CONNECT PASSWORD (it lasts 300 s without"
            " commands), or use: sondalog bus config"
        )
    if command not in COMMAND_NAMES:
        return (
            f"no reply from {module_id} to {command}: a module ignores commands it does not"
            f" know; the commands are {', '.join(sorted(COMMAND_NAMES))}"
        )
    return f"no reply from {module_id} to {command}, though it answers HELLO"
