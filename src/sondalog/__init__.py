"""sondalog: software ALA1 data logger and HCTMPS1 sensor server, with host tools."""

__version__ = "0.1.0"
