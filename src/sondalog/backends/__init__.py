"""Hardware backends of the device cores, registered by name (DESIGN.md point 4)."""
