"""Wiring: configuration becomes running devices, networks and mail hubs."""
