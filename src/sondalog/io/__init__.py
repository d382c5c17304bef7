"""The only asyncio, socket and tty code (DESIGN.md point 1): the clock, the one runtime
(:class:`~sondalog.io.host.DeviceHost`, serving any pure device core) and its transports: TCP
(:mod:`~sondalog.io.tcp`), pty (:mod:`~sondalog.io.pty`) and serial lines
(:mod:`~sondalog.io.serial_line`), and in-process links.

Import the modules themselves; this package imports nothing, so that ``sondalog --help``
stays fast.
"""
