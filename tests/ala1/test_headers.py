"""Header keywords (§8, spec notes §3)."""

from __future__ import annotations

import subprocess

from ala1_module import Module


def test_check_mismatch_is_silent(module: Module) -> None:
    assert module.ask("check 891 read date") == b""
    assert module.ask("check 890read date") == b""  # the space after N counts


def test_check_covers_the_rest_of_the_line_even_when_the_body_is_bad(module: Module) -> None:
    body = " read dat"
    assert module.ask(f"check {sum(body.encode())}{body}") == (
        f"check {sum(body.encode())}{body}".encode() + b"\r\nERROR\r\n"
    )


def test_crcsum_matches_the_real_cksum_program(module: Module) -> None:
    module.ok("write channel max number 3")
    module.ok("write channel name/Teplota vzduchu//Teplota vody//Napajeci napeti/")
    answer = module.ask("crcsum read channel name read i version read date")
    lines = answer.split(b"\r\n")
    assert lines[-1] == b"" and lines[-2] == b"OK"
    crc_line = lines[-3].decode()
    body = answer[: answer.index(crc_line.encode())]
    result = subprocess.run(["cksum"], input=body, capture_output=True, check=True)
    crc, length = result.stdout.split()[:2]
    assert crc_line == f"{crc.decode()},{length.decode()}"
    assert int(length) == len(body)


def test_crcsum_with_sum_counts_decorated_lines(module: Module) -> None:
    answer = module.ask("sum crcsum read i version")
    first, crc, ok, _ = answer.split(b"\r\n")
    assert first == b"%05d,2.10" % sum(b"2.10")
    result = subprocess.run(["cksum"], input=first + b"\r\n", capture_output=True, check=True)
    expected = b",".join(result.stdout.split()[:2])
    assert crc == b"%05d," % sum(expected) + expected
    assert ok == b"00154,OK"


def test_quiet_suppresses_ok_and_error(module: Module) -> None:
    assert module.ask("quiet read i version") == b"2.10\r\n"
    assert module.ask("quiet write i name/x/") == b""
    assert module.ask("quiet read bogus") == b""
    assert module.read("read i name") == "x"


def test_error_response_is_never_decorated(module: Module) -> None:
    assert module.ask("sum number 1 read bogus") == b"sum number 1 read bogus\r\nERROR\r\n"


def test_decoration_order(module: Module) -> None:
    module.ok("write date 20070618111806")
    module.ok("write i name/ALA/")
    answer = module.ask("endline/>/ number 7 date iname startline/</ read i version")
    assert answer == b"<ALA,20070618111806,7,2.10>\r\n<ALA,20070618111806,8,OK>\r\n"


def test_sum_is_computed_over_the_decorated_line(module: Module) -> None:
    answer = module.ask("sum startline/#/ read i version")
    line = b"#2.10"
    assert answer.startswith(b"%05d,#2.10\r\n" % sum(line))


def test_counters_keep_their_value_between_answers(module: Module) -> None:
    assert module.ask("counter 2 read i version") == b"0,2.10\r\n1,OK\r\n"
    assert module.ask("counter 2 read i version") == b"2,2.10\r\n3,OK\r\n"
    assert module.ask("counter 1 read i version") == b"0,2.10\r\n1,OK\r\n"


def test_counters_start_at_zero_at_power_up(tmp_path: object) -> None:
    import pathlib

    db = pathlib.Path(str(tmp_path)) / "m.sqlite"
    m = Module(db=db)
    m.ask("counter 1 read i version")
    assert Module(db=db).ask("counter 1 read nothing") == b"0,OK\r\n"


def test_headers_in_any_order_but_each_once(module: Module) -> None:
    assert module.ask("quiet number 1 read i version") == b"1,2.10\r\n"
    assert module.ask("number 1 quiet read i version") == b"1,2.10\r\n"
    module.error("number 1 number 2 read i version")
    module.error("number 1 counter 1 read i version")
    module.error("counter 5 read i version")
    module.error("pause 3600 read i version")
    module.error("comspeed 9601 read i version")
    module.error("startline/123456789012345678901/ read i version")
    module.error("endline/12345678901/ read i version")


def test_iaddress(module: Module) -> None:
    assert module.ask("iaddress/nobody/ read i version") == b"2.10\r\nOK\r\n"  # no own address
    module.ok("write i address/AB12/")
    assert module.ask("read i version") == b""
    assert module.ask("iaddress/XX/ read i version") == b""
    assert module.ask("iaddress/XX/ read bogus") == b""
    assert module.ask("iaddress/AB12/ read i version") == b"2.10\r\nOK\r\n"
    assert module.ask("iaddress/AB12/ read bogus") == b"iaddress/AB12/ read bogus\r\nERROR\r\n"


def test_named_command_bypasses_iaddress(module: Module) -> None:
    module.ok("write command 1 name verze")
    module.ok("write command 1 value/read i version/")
    module.ok("write i address/pw/")
    assert module.ask("verze") == b"2.10\r\nOK\r\n"
    assert module.ask("number 1 verze") == b"1,2.10\r\n2,OK\r\n"


def test_named_command_rules(module: Module) -> None:
    module.ok("write command 1 name a")
    module.ok("write command 1 value*read text/short/*")
    module.ok("write command 2 name ab")
    module.ok("write command 2 value*read text/long/*")
    assert module.ask("abc") == b"long\r\nOK\r\n"  # longest name that prefixes the line
    assert module.ask("aXYZ") == b"short\r\nOK\r\n"  # no & : the rest is ignored
    module.error("AB")  # names are case-sensitive
    module.ok("write command 3 name loop")
    module.ok("write command 3 value/a/")
    module.error("loop")  # a named command may not run another one
    module.ok("write command 4 name n")
    module.ok("write command 4 value*number 5 read text/x/*")
    assert module.ask("n") == b"5,x\r\n6,OK\r\n"  # the value's own headers apply
    module.error("number 1 n")  # ... and may not repeat the caller's


def test_pause_delays_the_command(module: Module) -> None:
    assert module.ask("pause 10 read i version") == b""
    assert module.engine.next_deadline() == module.now + 10
    assert module.feed(b"read date\r") == b""  # waits behind the paused command
    assert module.advance(9) == b""
    assert module.advance(1) == b"2.10\r\nOK\r\n20000101000010\r\nOK\r\n"


def test_comspeed_is_reported_with_the_answer(module: Module) -> None:
    out = module.engine.receive(module.line, b"comspeed 230400 read i version\r", module.now)
    assert [(o.data, o.baud) for o in out] == [(b"2.10\r\nOK\r\n", 230400)]
