"""Fixtures of the integration tests (helpers live in ``ala1_served``)."""

from ala1_served import serve, shared_logger

__all__ = ["serve", "shared_logger"]
