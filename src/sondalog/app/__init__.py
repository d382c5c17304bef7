"""Wiring: a site file becomes running devices, buses, networks and mail hubs (the one place
where cores, backends and I/O are assembled)."""
