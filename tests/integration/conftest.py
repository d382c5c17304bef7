"""Fixtures of the integration tests (helpers live in ``ala1_served``), and the end-of-run
report of real peers whose absence skipped tests (``peer_report``, for the whole session)."""

from ala1_served import serve, shared_logger
from peer_report import pytest_terminal_summary

__all__ = ["pytest_terminal_summary", "serve", "shared_logger"]
