"""Pure GSM cores: the Wavecom modem (:mod:`~sondalog.gsm.modem`), the network
(:mod:`~sondalog.gsm.network`, its typed output routed by :mod:`~sondalog.gsm.routing`),
their composition (:mod:`~sondalog.gsm.system`), GSM-7
(:mod:`~sondalog.protocol.gsm7`) and SMS PDUs (:mod:`~sondalog.gsm.pdu`). See ``docs/gsm.md``.
"""

from sondalog.gsm.modem import Modem, ModemConfig, Output
from sondalog.gsm.network import Network
from sondalog.gsm.phones import PhoneEvent
from sondalog.gsm.sms import Sms
from sondalog.gsm.system import GsmSystem, SystemOutput

__all__ = [
    "GsmSystem",
    "Modem",
    "ModemConfig",
    "Network",
    "Output",
    "PhoneEvent",
    "Sms",
    "SystemOutput",
]
