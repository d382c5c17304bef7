"""The site files behind the ready-made fixtures (docs/simulation.md, docs/gsm.md). Every
address is port 0: each test gets free ports."""

from __future__ import annotations

LOGGER_SITE = """
[logger]
supply = { model = "constant", value = 12.6 }

[[logger.analog]]
address = 16
signal = { model = "constant", value = 0.5 }

[logger.serve]
listen = "127.0.0.1:0"
"""

BUS_SITE = """
[bus]
baud = 9600

[[bus.modules]]
id = "T1"
kind = "temp"
signal = { model = "constant", value = 21.0 }

[[bus.modules]]
id = "H1"
kind = "hum"
signal = { model = "constant", value = 45.0 }

[bus.serve]
listen = "127.0.0.1:0"
"""

GSM_SITE = """
[logger]
supply = { model = "constant", value = 12.6 }

[logger.gsm]
signal = { model = "constant", value = 18 }
credit = { model = "constant", value = 250.0 }

[logger.serve]
listen = "127.0.0.1:0"
modem = "+420600000001"

[gsm]
smsc = "+420603052000"
logger_modem = "+420600000001"

[gsm.serve]
api = "127.0.0.1:0"

[[gsm.modem]]
number = "+420600000001"
credit = 250.0

[[gsm.phone]]
number = "+420700000001"
"""
