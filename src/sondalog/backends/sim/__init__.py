"""Simulation backends: seeded signal models and site files (DESIGN.md point 4)."""
