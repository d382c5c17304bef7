"""Non-volatile storage backends (SQLite)."""
