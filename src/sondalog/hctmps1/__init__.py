"""HCTMPS1 RS-485 sensor server, device side (DESIGN.md point 7: the public front door).

The pure module core (:class:`Hctmps1Module`), its framing (:func:`encode_frame`,
:class:`FrameDecoder`), the two variants and the EEPROM image. Transports live in
:mod:`sondalog.world.bus` and :mod:`sondalog.io`. Behaviour: docs/hctmps1.md.
"""

from sondalog.hctmps1.eeprom import EepromImage, EepromStore, MemoryEeprom
from sondalog.hctmps1.module import (
    COMMAND_NAMES,
    CONNECT_COMMANDS,
    CONNECT_TIMEOUT,
    QUEUE_MAX,
    Hctmps1Module,
    ModuleConfig,
    Output,
)
from sondalog.hctmps1.variants import HUM, TEMP, Kind, SensorSource, Variant, variant_for
from sondalog.protocol.hctmps1_frames import (
    BROADCAST,
    Frame,
    FrameDecoder,
    FrameError,
    encode_frame,
    is_valid_id,
    parse_frame,
    slot_time,
)
from sondalog.protocol.modbus_crc import crc16_modbus

__all__ = [
    "BROADCAST",
    "COMMAND_NAMES",
    "CONNECT_COMMANDS",
    "CONNECT_TIMEOUT",
    "HUM",
    "QUEUE_MAX",
    "TEMP",
    "EepromImage",
    "EepromStore",
    "Frame",
    "FrameDecoder",
    "FrameError",
    "Hctmps1Module",
    "Kind",
    "MemoryEeprom",
    "ModuleConfig",
    "Output",
    "SensorSource",
    "Variant",
    "crc16_modbus",
    "encode_frame",
    "is_valid_id",
    "parse_frame",
    "slot_time",
    "variant_for",
]
