"""Fixtures of the collector tests: real PostgreSQL and mosquitto (see ``services``)."""

from services import mosquitto, pg_dsn, postgres

__all__ = ["mosquitto", "pg_dsn", "postgres"]
