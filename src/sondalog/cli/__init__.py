"""The ``sondalog`` command line: parsing only; the work lives in the libraries (DESIGN.md 7)."""
