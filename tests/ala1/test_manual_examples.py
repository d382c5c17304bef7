"""The manual's examples of §2 to §8 and §10 that need no measurement, byte for byte.

Each test names the section its exchange comes from. Examples that read measured values or
the record belong to the measurement issue; their headers and chaining are covered here with
the same command shapes on stored parameters.
"""

from __future__ import annotations

import pytest
from ala1_module import Module

from sondalog.ala1 import Version


def test_2_2_sampling_period(module: Module) -> None:
    module.ok("write channel 1 sampling period 020000")
    assert module.ask("read channel 1 sampling period") == b"020000\r\nOK\r\n"
    module.ok("write channel 1 sampling period 000100")
    assert module.ask("read channel 1 sampling period") == b"000100\r\nOK\r\n"


@pytest.mark.parametrize(
    "command",
    [
        "write date 2007 06 01 09 25 30",
        "write date 20070601092530",
        "writedate20070601092530",
        "write      date      20070601092530",
    ],
)
def test_4_1_date_forms(module: Module, command: str) -> None:
    assert module.ask(command) == b"OK\r\n"
    assert module.ask("read date") == b"20070601092530\r\nOK\r\n"


@pytest.mark.parametrize(
    "command",
    [
        "write i description/Merici bod 1115/",
        "write   idescription*Merici bod 1115*",
        "writeidescriptionAMerici bod 1115A",
    ],
)
def test_4_1_description_boundaries(module: Module, command: str) -> None:
    module.ok(command)
    assert module.ask("read i description") == b"Merici bod 1115\r\nOK\r\n"


def test_4_1_check(module: Module) -> None:
    module.ok("write date 20070301090000")
    assert module.ask("check 890 read date") == b"20070301090000\r\nOK\r\n"
    assert module.ask("check826readdate") == b"20070301090000\r\nOK\r\n"


def test_6_2_date(module: Module) -> None:
    assert module.ask("write date 20070301090000") == b"OK\r\n"
    module.now += 3600 * 5  # the clock runs: five hours later, set only the time of day
    assert module.ask("write date 090000") == b"OK\r\n"
    assert module.ask("read date") == b"20070301090000\r\nOK\r\n"


def test_6_3_1_version() -> None:
    assert Module(Version.V1_16).ask("read i version") == b"1.16\r\nOK\r\n"
    assert Module(Version.V2_10).ask("read i version") == b"2.10\r\nOK\r\n"


def test_6_3_6_description(module: Module) -> None:
    assert module.ask("write i description*Varovny system 111*  ") == b"OK\r\n"
    assert module.ask("read i description") == b"Varovny system 111\r\nOK\r\n"


def test_6_5_3_channel_names(module: Module) -> None:
    assert module.ask("write channel max number 4") == b"OK\r\n"
    assert module.ask("write channel 2 name/Teplota vody/") == b"OK\r\n"
    assert (
        module.ask("writechannel010304name/Teplota vzduchu//Hladina vody//Napajeci napeti/")
        == b"OK\r\n"
    )
    assert (
        module.ask("readchannelname")
        == b"Teplota vzduchu,Teplota vody,Hladina vody,Napajeci napeti\r\nOK\r\n"
    )


def test_6_5_5_address(module: Module) -> None:
    assert module.ask("read channel 1 address") == b"21\r\nOK\r\n"
    assert module.ask("read channel 1 address x") == b"15\r\nOK\r\n"


@pytest.mark.parametrize(
    "command", ["write channel 1 2 format 0.1 0.2", "writechannel0102format0.10.2"]
)
def test_6_5_7_format(module: Module, command: str) -> None:
    module.ok("write channel max number 2")
    assert module.ask(command) == b"OK\r\n"
    assert module.ask("read channel format") == b"0.1,0.2\r\nOK\r\n"


def test_6_5_11_cal2(module: Module) -> None:
    module.ok("write channel 2 cal2 add all 7.55 3.5")
    module.ok("write channel 2 cal2 mult all 1.85 2.91")
    assert module.ask("read channel 2 cal2 add all") == b"7.550000,3.500000\r\nOK\r\n"
    assert module.ask("read channel 2 cal2 mult all") == b"1.850000,2.910000\r\nOK\r\n"


def test_6_5_12_convert_and_two_inputs(module: Module) -> None:
    module.ok("write channel 1 type 3")
    module.ok("write channel 1 convert file name/tabulka1/")
    assert module.read("read channel 1 convert 1 file name") == "tabulka1"
    module.ok("write channel 1 device all 3,4")
    module.ok("write channel 1 address all 0,1")
    assert module.read("read channel 1 device all") == "3,4"
    assert module.read("read channel 1 address all") == "0,1"
    assert module.read("read channel 1 device") == "3"


def test_6_5_13_to_6_5_16_sampling_parameters(module: Module) -> None:
    module.ok("write channel max number 5")
    module.ok("write channel 2 switch advance 3")
    module.ok("write channel 4 sampling period 010000")
    module.ok("write channel 4 sampling period 01")
    assert module.read("read channel 4 sampling period") == "010000"
    module.ok("write channel 04 05 sampling period 001000 003000")
    assert module.read("read channel 4 5 sampling period") == "001000,003000"
    module.ok("write channel 1 sampling start 20070301090000")
    module.ok("write channel 4 5 sampling start 20070301090000 20070301090000")
    assert module.read("read channel 5 sampling start") == "20070301090000"
    module.ok("write channel 1 sampling period 000100")
    module.ok("write channel 1 average samples 60")
    module.ok("write channel 1 record change 0")
    module.ok("write channel 4 record change 0.02")
    module.ok("write channel 4 format 0.2")
    assert module.read("read channel 4 record change") == "0.02"
    module.ok("write channel 4 record samples 6")
    assert module.read("read channel 4 record samples") == "6"


def test_6_5_14_2_start_next_whole_hour_form(module: Module) -> None:
    module.ok("write date 20070301093512")
    module.ok("write channel 1 sampling start 0000")
    assert module.read("read channel 1 sampling start") == "20070301090000"


def test_6_6_2_last_read_point(module: Module) -> None:
    module.ok("write record last 1 read/200707160000/")
    assert module.read("read record last read") == "200707160000"


def test_6_7_1_output(module: Module) -> None:
    module.ok("write output 7 device 8")
    assert module.read("read output 7 device") == "8"


def test_6_8_max_numbers() -> None:
    m116, m210 = Module(Version.V1_16), Module(Version.V2_10)
    assert m116.ask("read command max number") == b"4\r\nOK\r\n"
    assert m210.ask("read command max number") == b"40\r\nOK\r\n"
    assert m116.ask("read address max number") == b"8\r\nOK\r\n"
    assert m210.ask("read address max number") == b"40\r\nOK\r\n"
    assert m116.ask("read message max number") == b"2\r\nOK\r\n"
    assert m210.ask("read message max number") == b"40\r\nOK\r\n"


def test_6_8_3_named_command_zmer(module: Module) -> None:
    assert module.ask("write command 1 name zmer") == b"OK\r\n"
    assert module.ask("write command 1 value/read channel name/") == b"OK\r\n"
    module.ok("write channel max number 2")
    module.ok("write channel name/Teplota//Vlhkost/")
    assert module.ask("zmer") == b"Teplota,Vlhkost\r\nOK\r\n"


def test_6_8_3_named_command_ctizaznam_expands_ampersand(module: Module) -> None:
    assert module.ask("write command 1 name ctizaznam") == b"OK\r\n"
    assert module.ask("write command 1 value/read record 4 from date &/") == b"OK\r\n"
    assert module.read("read command 1 value") == "read record 4 from date &"
    # The record read itself arrives with the record issue; the expansion is shown with text:
    module.ok("write command 2 name opakuj")
    module.ok("write command 2 value/read text &/")
    assert module.ask("opakuj200707") == b"200707\r\nOK\r\n"
    # "read text /Dobry/": the space after "text" is the boundary (spec notes §2)
    assert module.ask("opakuj/Dobry/") == b"/Dobry/\r\nOK\r\n"


def test_6_8_4_message_setup(module: Module) -> None:
    module.ok("write message 1 command 1")
    module.ok("write message 1 address 1")
    module.ok("write address 1 type email")
    module.ok("write command 1 value/read record 1000 from lastread shift/")
    module.ok("write address 1 type sms")
    module.ok("write command 1 value/read channel 1 value/")
    assert module.read("read address 1 type") == "SMS"


def test_6_9_6_10_6_11_examples(module: Module) -> None:
    module.ok("write command channel switch hold 000100")
    assert module.read("read command channel switch hold") == "000100"
    module.ok("write address 1 type email")
    module.ok("write address 1 value/MyALA@ala1.com/")
    assert module.read("read address 1 value") == "MyALA@ala1.com"
    module.ok("write com speed 9600")
    module.ok("write com device wavecom41")
    assert module.read("read com device") == "WAVECOM41"
    module.ok("write com network pop3 address/jan.novak@posta.cz:heslo@pop3.posta.cz")
    assert module.read("read com network pop3 address") == "jan.novak@posta.cz:heslo@pop3.posta.cz"


def test_6_14_messages(module: Module) -> None:
    module.ok("write message 1 period 240000")
    module.ok("write message of record function yes")
    module.ok("write message of channel function up")
    assert module.read("read message 1 of record function") == "YES"
    assert module.read("read message 1 of channel function") == "UP"


def test_6_15_memory_partition(module: Module) -> None:
    assert module.ask("write file record size 983040") == b"OK\r\n"
    assert module.ask("write file list size 256") == b"OK\r\n"
    assert module.ask("write file data size 51200") == b"OK\r\n"
    assert module.ask("read file free size") == b"14080\r\nOK\r\n"


def test_6_18_nothing(module: Module) -> None:
    assert module.ask("read nothing") == b"OK\r\n"


def test_6_19_text(module: Module) -> None:
    assert module.ask("read text/Dobry den./") == b"Dobry den.\r\nOK\r\n"


def test_7_1_whole_command_chaining(module: Module) -> None:
    module.ok("write channel 1 name/Teplota vzduchu/")
    assert (
        module.ask("readtext/Zde je zmerena hodnota prvnio kanalu/readchannel1name")
        == b"Zde je zmerena hodnota prvnio kanalu\r\nTeplota vzduchu\r\nOK\r\n"
    )


def test_7_2_chaining_after_first_keyword_with_number(module: Module) -> None:
    module.ok("write channel 1 name/Teplota vzduchu/")
    assert (
        module.ask("number1 read channel 1 name 1 format")
        == b"1,Teplota vzduchu\r\n2,0.1\r\n3,OK\r\n"
    )


def test_8_4_2_sum(module: Module) -> None:
    module.ok("write date 20070618111806")
    assert module.ask("sum read date") == b"00713,20070618111806\r\n00154,OK\r\n"


def test_8_5_4_startline_endline(module: Module) -> None:
    module.ok("write channel 2 name/10.5/")
    assert (
        module.ask("quiet startline/Teplota: /endline/ stupnu/ read channel 2 name")
        == b"Teplota: 10.5 stupnu\r\n"
    )


def test_8_5_5_endline_shows_trailing_spaces(module: Module) -> None:
    module.ok("write i description/Stanoviste 1 /")
    assert module.ask("quiet endline/*/ read i description") == b"Stanoviste 1 *\r\n"


def test_8_5_8_number_and_8_5_9_date(module: Module) -> None:
    module.ok("write date 20060701090532")
    module.ok("write channel 2 name/10.5/")
    assert module.ask("number1readchannel2name") == b"1,10.5\r\n2,OK\r\n"
    assert module.ask("date read channel 2 name") == b"20060701090532,10.5\r\n20060701090532,OK\r\n"


def test_10_1_record_space(module: Module) -> None:
    assert module.ask("read record space") == b"1048576\r\nOK\r\n"
