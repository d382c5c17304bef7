"""Implementations of the device ports, registered by name: ``sim`` (simulated hardware from
a site file), ``linux`` (real sensors), and ``store`` (SQLite non-volatile memory)."""
