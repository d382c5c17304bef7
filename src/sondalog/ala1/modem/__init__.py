"""The logger's driver of its ALA GPRS modem (manual §3.4.6, §6.10-§6.13, §6.11.7; gsm.md).

Pure: bytes from the modem and ``now`` in, AT bytes out, its own deadlines. When ``com device``
is ``wavecom40/41/42`` the engine's com line is the modem line and its bytes go through
:class:`~sondalog.ala1.modem.driver.ModemDriver` instead of the command parser
(:mod:`~sondalog.ala1.modem.link` is the glue with the engine). ``docs/gsm.md`` "The logger's
modem" describes the behaviour.
"""

from sondalog.ala1.modem.driver import ModemDriver
from sondalog.ala1.modem.link import ModemLink

__all__ = ["ModemDriver", "ModemLink"]
