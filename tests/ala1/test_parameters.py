"""The parameter tree (§6.1), factory values (§11) and the limits of both versions."""

from __future__ import annotations

from pathlib import Path

import pytest
from ala1_module import Module

from sondalog.ala1 import Version

#: §11, transcribed by hand (not from the parameter table) for a 2.10 module, serial 000001.
FACTORY = {
    "i version": "2.10",
    "i device": "ALA1",
    "i snumber": "000001",
    "i name": "",
    "i description": "000001",
    "i type": "000001",
    "i address": "",
    "date": "20000101000000",
    "device 1 type": "MSP430ADC",
    "device 8 type": "MSP430ADC",
    "device 3 cal mult": "2.500000",
    "device 3 cal add": "0.000000",
    "channel max number": "1",
    "channel 1 name": "Supply[V]",
    "channel 1 device": "1",
    "channel 1 address": "21",
    "channel 1 type": "1",
    "channel 1 format": "0.1",
    "channel 1 sample": "",
    "channel 1 cal mult value": "1",
    "channel 1 cal mult format": "0.0",
    "channel 1 cal add value": "0",
    "channel 1 cal add format": "0.0",
    "channel 1 cal2 mult": "1.000000",
    "channel 1 cal2 add": "0.000000",
    "channel 1 switch output": "1",
    "channel 1 switch advance": "1",
    "channel 1 convert file name": "",
    "channel 1 convert 2 file name": "",
    "channel 1 sampling period": "000000",
    "channel 1 sampling start": "20000101000000",
    "channel 1 average samples": "0",
    "channel 1 record change": "0.0",
    "channel 1 record samples": "0",
    "channel 1 record value": "",
    "channel 12 name": "Supply[V]",
    "record last read": "",
    "record last 4 read": "",
    "record space": "1048576",
    "record type": "CYCLIC",
    "record status": "0,0.00,CLEAR",
    "output 1 device": "1",
    "output 1 address": "7",
    "output 1 value": "NO",
    "output 2 device": "0",
    "output 7 address": "0",
    "output 7 value": "NO",
    "command 1 name": "",
    "command 40 value": "",
    "command channel switch hold": "000005",
    "address 1 type": "SMS",
    "address 1 value": "",
    "com speed": "9600",
    "com max speed": "230400",
    "com transmitter mode": "SAVING",
    "com device": "LOCAL",
    "com network smc": "",
    "com network apn address": "",
    "com network smtp address": "",
    "com network pop3 address": "",
    "com network pop3 size": "10000",
    "com network pop3 time": "120",
    "com network delay": "0",
    "com status sim credit code": "",
    "sms command boundary": "##*#",
    "sms email address start": "startemail",
    "sms email address end": "endemail",
    "email send from": "",
    "email send subject": "",
    "message 1 address": "1",
    "message 1 command": "1",
    "message 1 period": "000000",
    "message 1 start": "20000101000000",
    "message 1 of record function": "NO",
    "message 1 of channel function": "NO",
    "message 1 of channel number": "1",
    "message 1 of channel value": "0.0",
    "message 1 of channel hysteresis": "0.0",
    "file record size": "1048576",
    "file list size": "0",
    "file data size": "0",
    "file free size": "0",
    "global timing": "8",
}


@pytest.mark.parametrize(("path", "value"), FACTORY.items())
def test_factory_values(module: Module, path: str, value: str) -> None:
    assert module.ask(f"read {path}") == f"{value}\r\nOK\r\n".encode()


def test_program_version_names_sondalog(module: Module) -> None:
    assert module.read("read i program").startswith("sondalog ")


@pytest.mark.parametrize(
    "command",
    [
        "write i version/3.00/",  # read-only
        "write i snumber/1/",
        "write record space 5",
        "write file free size 256",
        "write channel 1 sample 5",
        "write command max number 5",
        "read global reset",  # write-only
        "read com close",
        "read record status clear",
        "read channel 1",  # a subtree, not a leaf
        "read i",
        "read",
        "write",
        "read channel 1 name extra",
        "write i name/123456789012345678901/",  # longer than 20
        "write i address/12345678901/",  # longer than 10
        "write channel 1 type 4",
        "write channel 1 type",
        "write channel 1 format 1.",
        "write channel 1 format 10.2",
        "write channel 1 device 9",
        "write channel 1 switch output 8",
        "write channel 1 record change -0.5",
        "write channel 13 name/x/",
        "write channel 0 name/x/",
        "write channel 123 name/x/",  # odd run of digits
        "write channel 1 2 name/only one/",  # one value per channel
        "write device 9 type ds18b20",
        "write device type ds18b20",
        "write device 1 type ds18b21",
        "write output 8 value 1",
        "write com speed 9601",
        "write global timing 16",
        "write date 20070230120000",  # no 30 February
        "write date 2007030112",  # 10 digits are MMDDhhmmss: month 20
        "write date 123",
        "write date 20070301250000",
        "write channel 1 sampling period 960001",
        "write channel 1 sampling period 006000",
        "write channel 1 sampling period 999100",  # 91 days
        "write channel 1 sampling period 999901",  # month only for messages
        "write channel 1 sampling period 1",
        "write message 1 period 999902",
        "write message 41 period 01",
        "write message 1 address 1,2,3,4,5,6,7,8,9,10,11",
        "write message 1 address 41",
        "write message 1 command 41",
        "write address 1 type ringvoice 41",
        "write address 1 type fax",
        "write file record size 1000",  # not a multiple of 256
        "write file list size 256",  # record area still covers the memory
        "write record type spiral",
        "write com mode gsm",  # com device is LOCAL
        "read com mode",
        "write global reset read date",  # nothing may follow
        "write channel 1 address x FFFFFFFFFFFFFFFFF",  # 68 bits
    ],
)
def test_bad_commands_get_the_error_response(module: Module, command: str) -> None:
    module.error(command)


def test_version_limits() -> None:
    old, new = Module(Version.V1_16), Module(Version.V2_10)
    old.error("write channel max number 9")
    old.ok("write channel max number 8")
    new.ok("write channel max number 12")
    old.error("write command 5 name x")
    new.ok("write command 40 name x")
    old.error("write address 9 type sms")
    new.ok("write address 40 type sms")
    old.error("write message 3 period 01")
    new.ok("write message 40 period 01")
    old.error("write message 1 address 1,2")
    new.ok("write message 1 address 1,2,3,4,5,6,7,8,9,10")
    old.error("write channel 1 address 65536")
    new.ok("write channel 1 address 18446744073709551615")
    assert new.read("read channel 1 address x") == "FFFFFFFFFFFFFFFF"


def test_channel_list_forms(module: Module) -> None:
    module.ok("write channel max number 12")
    module.ok("write channel 1 3 12 average samples 1 3 12")
    assert module.read("read channel 010312 average samples") == "1,3,12"
    assert module.read("read channel 1 3 average samples") == "1,3"
    assert module.read("read channel 12 average samples") == "12"
    module.ok("write channel average samples 0 0 0 0 0 0 0 0 0 0 0 7")
    assert module.read("read channel 12 1 average samples") == "7,0"


def test_hexadecimal_address_write(module: Module) -> None:
    module.ok("write channel 1 address x FF00")
    assert module.read("read channel 1 address") == "65280"
    assert module.read("read channel 1 address x") == "FF00"


def test_device_type_restores_factory_calibration(module: Module) -> None:
    module.ok("write device 2 cal mult 1.234 2 cal add 0.5")
    assert module.read("read device 2 cal mult") == "1.234000"
    module.ok("write device 2 type ds18b20")
    assert module.read("read device 2 cal mult") == "3276.800000"
    assert module.read("read device 2 cal add") == "0.000000"
    module.ok("write device 2 type MSP430TA")
    assert module.read("read device 2 cal mult") == "1.000000"
    assert module.read("read device 2 type") == "MSP430TA"


def test_calibration_values_read_in_their_format(module: Module) -> None:
    module.ok("write channel 3 cal mult value 10")
    module.ok("write channel 3 cal add value -0.8")
    assert module.read("read channel 3 cal add value") == "-1"  # format 0.0
    module.ok("write channel 3 cal add format 5.2")
    assert module.read("read channel 3 cal add value") == "-0.80"
    assert module.read("read channel 3 cal mult value") == "10"


def test_enumerations_any_case_read_upper(module: Module) -> None:
    module.ok("write record type Linear")
    assert module.read("read record type") == "LINEAR"
    module.ok("write com transmitter mode follow")
    assert module.read("read com transmitter mode") == "FOLLOW"


def test_output_values(module: Module) -> None:
    module.ok("write output 3 value 0")
    assert module.read("read output 3 value") == "0"
    module.ok("write output 3 value 2.5")
    assert module.read("read output 3 value") == "1"
    module.ok("write output 3 value no")
    assert module.read("read output 3 value") == "NO"


def test_address_type_with_message_number(module: Module) -> None:
    module.ok("write address 2 type ringdata 7")
    assert module.read("read address 2 type") == "RINGDATA,7"


def test_com_mode_is_another_view_of_com_device(module: Module) -> None:
    module.ok("write com device wavecom40")
    assert module.read("read com mode") == "SAVING"
    module.ok("write com device mode gprs")
    assert module.read("read com device") == "WAVECOM42"
    assert module.read("read com device mode") == "GPRS"


def test_network_smsc_is_smc(module: Module) -> None:
    module.ok("write com network smsc/+420602909909/")
    assert module.read("read com network smc") == "+420602909909"


def test_message_values_use_the_watched_channels_format(module: Module) -> None:
    module.ok("write channel 3 format 0.3")
    module.ok("write message 2 of channel number 3 2 of channel value 1.5")
    module.ok("write message 2 of channel hysteresis 0.25")
    assert module.read("read message 2 of channel value") == "1.500"
    assert module.read("read message 2 of channel hysteresis") == "0.250"


def test_memory_partition_rules(module: Module) -> None:
    module.ok("write file record size 983040 list size 256 data size 51200")
    assert module.read("read file free size") == "14080"
    module.error("write file data size 65536")  # beyond the memory
    module.ok("write file list size 512")  # zeroes the data area
    assert module.read("read file data size") == "0"
    module.ok("write file record size 524288")  # zeroes both
    assert module.read("read file list size") == "0"
    assert module.read("read file free size") == "524288"


def test_global_reset_keeps_communication_parameters(module: Module) -> None:
    module.ok("write com speed 115200 transmitter mode on device wavecom42")
    module.ok("write com max speed 9600")
    module.ok("write channel max number 5 name/a//b//c//d//e/")
    module.ok("write date 20070301090000")
    module.ok("write global reset")
    assert module.read("read com speed") == "115200"
    assert module.read("read com transmitter mode") == "ON"
    assert module.read("read com device") == "WAVECOM42"
    assert module.read("read com max speed") == "230400"
    assert module.read("read channel max number") == "1"
    assert module.read("read channel 5 name") == "Supply[V]"
    assert module.read("read date") == "20070301090000"  # a clock, not a setting


def test_record_status_clear(module: Module) -> None:
    module.ok("write record last 2 read/2007/")
    module.ok("write record status clear")
    assert module.read("read record last 2 read") == ""


def test_a_failing_line_changes_nothing(module: Module) -> None:
    module.error("write i name/changed/ write channel 1 type 4")
    assert module.read("read i name") == ""
    module.error("write date 20070301090000 read bogus")
    assert module.read("read date") == "20000101000000"


def test_reads_see_earlier_writes_of_the_same_line(module: Module) -> None:
    assert module.ask("write i name/new/ read i name") == b"new\r\nOK\r\n"


def test_parameters_survive_a_restart(tmp_path: Path) -> None:
    db = tmp_path / "ala1.sqlite"
    first = Module(db=db)
    first.ok("write i name/persist/ write channel max number 3")
    first.ok("write date 20070301090000")
    first.ok("write global timing 64")
    first.store.close()
    second = Module(db=db)
    second.now = first.now + 125  # the battery-backed clock kept running
    assert second.read("read i name") == "persist"
    assert second.read("read channel max number") == "3"
    assert second.read("read global timing") == "64"
    assert second.read("read date") == "20070301090205"


def test_global_reset_survives_a_restart(tmp_path: Path) -> None:
    db = tmp_path / "ala1.sqlite"
    first = Module(db=db)
    first.ok("write i name/x/ write com speed 19200")
    first.ok("write global reset")
    first.store.close()
    second = Module(db=db)
    assert second.read("read i name") == ""
    assert second.read("read com speed") == "19200"
