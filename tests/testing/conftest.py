"""The plugin's fixtures for these tests, whether or not sondalog is installed with its
``pytest11`` entry point (a checkout run with PYTHONPATH=src is not): imported here, they
are this folder's fixtures (and override the installed plugin's, which are the same)."""

from sondalog.testing import sondalog_logger, sondalog_site

__all__ = ["sondalog_logger", "sondalog_site"]
