"""Mail over real TCP: a POP3 server, an SMTP server and a client driver (asyncio)."""
