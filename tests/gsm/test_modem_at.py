"""The modem's AT dialect, byte-exact (gsm.md §2): command lines, echo, results, errors,
identification, registration, signal, radio, USSD."""

from __future__ import annotations

from gsm_helpers import MODEM, Bench
from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.gsm.atline import AtCommand, parse_line


def test_parse_line() -> None:
    assert parse_line("at+cmgf=1;+CSQ ; E0V1") == [
        AtCommand("+CMGF", "=", "1"),
        AtCommand("+CSQ"),
        AtCommand("E", "", "0"),
        AtCommand("V", "", "1"),
    ]
    assert parse_line('AT+CMGS="+420700000001"') == [AtCommand("+CMGS", "=", '"+420700000001"')]
    assert parse_line("ATD+420700000001;") == [AtCommand("D", "=", "+420700000001;")]
    assert parse_line("ATS0=2S0?") == [AtCommand("S0", "=", "2"), AtCommand("S0", "?")]
    assert parse_line("hello") is None


def test_echo_on_by_default_then_off() -> None:
    b = Bench(echo=True)
    assert b.at("AT") == b"AT\r\r\nOK\r\n"
    assert b.at("ATE0") == b"ATE0\r\r\nOK\r\n"
    assert b.at("AT") == b"\r\nOK\r\n"


def test_noise_and_escape_are_ignored() -> None:
    b = Bench()
    assert b.send(b"\x1b") == b""
    assert b.at("garbage") == b""
    assert b.at("\x1bAT") == b"\r\nOK\r\n"
    assert b.send(b"A") + b.send(b"T\x08\x08AT\r\n") == b"\r\nOK\r\n"


def test_identification() -> None:
    b = Bench()
    assert b.at("AT+CGMI") == b"\r\nWAVECOM MODEM\r\n\r\nOK\r\n"
    assert b.at("AT+CGMM") == b"\r\nMULTIBAND  900E  1800\r\n\r\nOK\r\n"
    assert b.at("AT+CGSN;+CIMI") == b"\r\n356938035643809\r\n\r\n230011234567890\r\n\r\nOK\r\n"
    assert b.at("AT+CGMR").startswith(b"\r\nR74_00gg")


def test_errors_plain_and_cme() -> None:
    b = Bench()
    assert b.at("AT+NOSUCH") == b"\r\nERROR\r\n"
    assert b.at("AT+CFUN=7") == b"\r\nERROR\r\n"
    assert b.at("AT+CMEE=1") == b"\r\nOK\r\n"
    assert b.at("AT+CFUN=7") == b"\r\n+CME ERROR: 3\r\n"
    assert b.at("AT+NOSUCH") == b"\r\nERROR\r\n"  # syntax stays plain ERROR
    assert b.at("AT+CMEE?") == b"\r\n+CMEE: 1\r\n\r\nOK\r\n"
    assert b.at("AT+CSQ;+CMGR=99;+CSQ") == b"\r\n+CSQ: 18,0\r\n\r\n+CMS ERROR: 321\r\n"


def test_numeric_results_and_quiet() -> None:
    b = Bench()
    assert b.at("ATV0") == b"0\r"
    assert b.at("AT+CSQ") == b"+CSQ: 18,0\r\n0\r"
    assert b.at("AT+BAD") == b"4\r"
    assert b.at("ATV1Q1") == b""
    assert b.at("ATQ0") == b"\r\nOK\r\n"


def test_registration_signal_and_radio() -> None:
    b = Bench()
    assert b.at("AT+CREG?") == b"\r\n+CREG: 0,1\r\n\r\nOK\r\n"
    b.net(lambda n, t: n.set_signal(MODEM, 25, t))
    assert b.at("AT+CSQ") == b"\r\n+CSQ: 25,0\r\n\r\nOK\r\n"
    assert b.at("AT+CREG=1") == b"\r\nOK\r\n"
    assert b.at("AT+CFUN=0") == b"\r\nOK\r\n\r\n+CREG: 0\r\n"
    assert b.at("AT+CFUN?;+CREG?;+CSQ") == (
        b"\r\n+CFUN: 0\r\n\r\n+CREG: 1,0\r\n\r\n+CSQ: 99,99\r\n\r\nOK\r\n"
    )
    assert b.at("AT+CFUN=1") == b"\r\nOK\r\n\r\n+CREG: 1\r\n"
    assert b.at("AT+CSQ") == b"\r\n+CSQ: 25,0\r\n\r\nOK\r\n"


def test_coverage_loss_is_searching() -> None:
    b = Bench()
    b.at("AT+CREG=1")
    assert b.net(lambda n, t: n.set_coverage(MODEM, False, t)).line(MODEM) == b"\r\n+CREG: 2\r\n"
    assert b.at("AT+CREG?") == b"\r\n+CREG: 1,2\r\n\r\nOK\r\n"


def test_ussd_credit() -> None:
    b = Bench()
    b.network.set_credit(MODEM, 250)
    assert b.at('AT+CUSD=1,"*101#",15') == (
        b'\r\nOK\r\n\r\n+CUSD: 0,"Your credit is 250.00 CZK.",15\r\n'
    )
    assert b.at('AT+CUSD=1,"*999#",15') == b"\r\nOK\r\n\r\n+CUSD: 4\r\n"
    b.at("AT+CMEE=1;+CFUN=0")
    assert b.at('AT+CUSD=1,"*101#",15') == b"\r\n+CME ERROR: 30\r\n"


def test_settings_reads() -> None:
    b = Bench()
    assert b.at("AT+CSCA?") == b'\r\n+CSCA: "+420603052000",145\r\n\r\nOK\r\n'
    assert b.at("AT+CPIN?") == b"\r\n+CPIN: READY\r\n"  # no OK, as on a Wavecom
    assert b.at('AT+CSCS="UCS2";+CSCS?') == b'\r\n+CSCS: "UCS2"\r\n\r\nOK\r\n'
    assert b.at("AT+IPR?") == b"\r\n+IPR: 9600\r\n\r\nOK\r\n"
    assert b.at("AT&F;+CMEE?") == b"\r\n+CMEE: 0\r\n\r\nOK\r\n"


AT_WORDS = st.sampled_from(
    [
        "AT",
        "+CMGF=",
        "+CMGS=",
        "+CMGR=",
        "+CMGL=",
        "+CMGD=",
        "+CSCS=",
        "+CPMS=",
        "+WIPBR=",
        "+WIPCREATE=",
        "+WIPDATA=",
        "+CUSD=",
        "E",
        "V",
        "Q",
        "H",
        "A",
        "D",
        "O",
        "S0=",
        "?",
        "=?",
        '"',
        ",",
        ";",
        "1",
        "0",
        "4",
        "16",
        "\r",
        "\n",
        "\x1a",
        "\x1b",
        "\x08",
        "+++",
        "ALL",
    ]
)


@settings(max_examples=150, deadline=None)
@given(st.lists(AT_WORDS | st.binary(max_size=8), max_size=40))
def test_garbage_never_breaks_the_modem(chunks: list[str | bytes]) -> None:
    b = Bench()
    for chunk in chunks:
        b.send(chunk.encode("latin-1") if isinstance(chunk, str) else chunk)
        b.later(0.3)
    b.later(2.0)  # a pending escape completes
    b.send(b"\x1b")
    b.later(2.0)
    out = b.at("\rATQ0V1E0;+CMEE=0")
    out += b.at("ATH;+CSQ")
    assert out.endswith(b"OK\r\n")


def test_trace_hook_sees_the_line_both_ways() -> None:
    from sondalog.gsm.modem import Modem
    from sondalog.gsm.trace import trace_line

    seen: list[tuple[str, bytes, float]] = []
    modem = Modem(trace=lambda d, data, t: seen.append((d, data, t)))
    modem.receive(b"ATE0\r", 1764464400.0)
    assert seen == [("rx", b"ATE0\r", 1764464400.0), ("tx", b"ATE0\r\r\nOK\r\n", 1764464400.0)]
    assert trace_line(*seen[1]) == (
        "2025-11-30T01:00:00.000Z  modem>logger  ATE0\\r\\r\\nOK\\r\\n\n"
    )
    assert trace_line("rx", b"\x1a\x1b\xff", 0.5) == (
        "1970-01-01T00:00:00.500Z  logger>modem  <ctrl-z><esc>\\xff\n"
    )


def test_cell_operator_and_gprs_registration() -> None:
    b = Bench()
    assert b.at("AT+CREG=2;+CREG?") == b'\r\n+CREG: 2,1,"0FA1","2B3C"\r\n\r\nOK\r\n'
    assert b.at("AT+CGREG=2;+CGREG?") == b'\r\n+CGREG: 2,1,"0FA1","2B3C"\r\n\r\nOK\r\n'
    assert b.at("AT+COPS?") == b'\r\n+COPS: 0,0,"SONDALOG GSM"\r\n\r\nOK\r\n'
    assert b.at("AT+COPS=3,2;+COPS?") == b'\r\n+COPS: 0,2,"23001"\r\n\r\nOK\r\n'
    assert b.at("AT+CGATT?") == b"\r\n+CGATT: 0\r\n\r\nOK\r\n"
    b.at("AT+WIPCFG=1;+WIPBR=1,6;+WIPBR=4,6,0")
    assert b.at("AT+CGATT?") == b"\r\n+CGATT: 1\r\n\r\nOK\r\n"
    b.at("AT+CFUN=0")
    assert b.at("AT+COPS?;+CGATT?") == b"\r\n+COPS: 0\r\n\r\n+CGATT: 0\r\n\r\nOK\r\n"


def test_ussd_in_ucs2_character_set() -> None:
    b = Bench()
    b.network.set_credit(MODEM, 12.5)
    b.at('AT+CSCS="UCS2"')
    out = b.at('AT+CUSD=1,"002A0031003000310023",15')  # "*101#"
    text = "Your credit is 12.50 CZK.".encode("utf-16-be").hex().upper()
    assert out == f'\r\nOK\r\n\r\n+CUSD: 0,"{text}",15\r\n'.encode()
