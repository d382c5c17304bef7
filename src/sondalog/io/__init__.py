"""The only asyncio, socket and tty code: thin adapters around the pure cores."""
