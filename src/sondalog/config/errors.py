"""The one error type of every configuration format."""

from __future__ import annotations

from pathlib import Path


class ConfigError(ValueError):
    """A configuration is wrong: ``path``, the dotted ``field`` and the ``line`` if known.

    The one error type of every configuration format (site, board, collector, GSM network,
    mail hub, request bodies of the HTTP APIs)."""

    def __init__(
        self, path: Path | None, field: str, message: str, line: int | None = None
    ) -> None:
        where = str(path) if path is not None else "<config>"
        if line is not None:
            where += f":{line}"
        super().__init__(f"{where}: {field}: {message}" if field else f"{where}: {message}")
        self.message = message
        self.path = path
        self.field = field
        self.line = line
