"""WIPsoft GPRS/TCP on the modem and the network's IP gateway (gsm.md §1-§3)."""

from __future__ import annotations

from gsm_helpers import MODEM, Bench

from sondalog.gsm import gateway as gw


def gprs(b: Bench) -> None:
    b.at("AT+CMEE=1")
    assert b.at("AT+WIPCFG=1") == b"\r\nOK\r\n"
    assert b.at("AT+WIPBR=1,6") == b"\r\nOK\r\n"
    assert b.at('AT+WIPBR=2,6,11,"internet"') == b"\r\nOK\r\n"
    assert b.at("AT+WIPBR=4,6,0") == b"\r\nOK\r\n"
    assert b.network.subscriber(MODEM).attached


def test_tcp_client_to_a_named_host() -> None:
    b = Bench()
    b.network.gateway.hosts["smtp.example.net"] = "127.0.0.1"
    gprs(b)
    assert b.at("AT+WIPBR?") == b"\r\n+WIPBR: 6,1\r\n\r\nOK\r\n"
    assert b.at('AT+WIPCREATE=2,1,"smtp.example.net",2525') == b"\r\nOK\r\n"
    (connect,) = b.last.ip
    assert connect == gw.Connect(connect.conn, "127.0.0.1", 2525)  # type: ignore[union-attr]
    conn = connect.conn  # type: ignore[union-attr]
    assert b.system.ip_event(gw.Connected(conn), b.now).line(MODEM) == b"\r\n+WIPREADY: 2,1\r\n"
    # the server greets before the DTE entered data mode: announced, then kept
    out = b.system.ip_event(gw.Received(conn, b"220 hello\r\n"), b.now).line(MODEM)
    assert out == b"\r\n+WIPDATA: 2,1,11\r\n"
    assert b.at("AT+WIPDATA=2,1,1") == b"\r\nCONNECT\r\n220 hello\r\n"
    b.send(b"EHLO x\r\n")
    assert b.last.ip == [gw.Send(conn, b"EHLO x\r\n")]
    assert b.system.ip_event(gw.Received(conn, b"250 ok\r\n"), b.now).line(MODEM) == b"250 ok\r\n"
    b.later(1.0)
    b.send(b"+++")
    assert b.later(1.0) == b"\r\nOK\r\n"
    assert b.at("AT+WIPCLOSE=2,1") == b"\r\nOK\r\n"
    assert b.last.ip == [gw.Close(conn)]


def test_unknown_host_and_refused_connection() -> None:
    b = Bench()
    gprs(b)
    b.at('AT+WIPCREATE=2,1,"nowhere.example",25')
    assert b.last.line(MODEM) == b"\r\nOK\r\n\r\n+WIPERROR: 2,1,842\r\n"
    b.at('AT+WIPCREATE=2,1,"127.0.0.1",25')
    conn = b.last.ip[0].conn  # type: ignore[union-attr]
    out = b.system.ip_event(gw.ConnectFailed(conn), b.now).line(MODEM)
    assert out == b"\r\n+WIPERROR: 2,1,842\r\n"


def test_wip_errors() -> None:
    b = Bench()
    b.at("AT+CMEE=1")
    assert b.at("AT+WIPBR=1,6") == b"\r\n+CME ERROR: 803\r\n"
    b.at("AT+WIPCFG=1")
    assert b.at("AT+WIPCFG=1") == b"\r\n+CME ERROR: 844\r\n"
    assert b.at("AT+WIPBR=1,5") == b"\r\n+CME ERROR: 805\r\n"
    assert b.at('AT+WIPCREATE=2,1,"127.0.0.1",25') == b"\r\n+CME ERROR: 803\r\n"
    b.at("AT+WIPBR=1,6")
    b.net(lambda n, t: n.set_coverage(MODEM, False, t))
    assert b.at("AT+WIPBR=4,6,0") == b"\r\n+CME ERROR: 812\r\n"
    b.net(lambda n, t: n.set_coverage(MODEM, True, t))
    b.at("AT+WIPBR=4,6,0")
    assert b.at("AT+WIPDATA=2,3,1") == b"\r\n+CME ERROR: 830\r\n"
    assert b.at("AT+WIPCLOSE=2,3") == b"\r\n+CME ERROR: 830\r\n"
    assert b.at("AT+WIPCREATE=1,1,5000") == b"\r\n+CME ERROR: 834\r\n"


def test_port_10001_published_and_peer_close_in_data_mode() -> None:
    b = Bench()
    b.network.gateway.publish(MODEM, 10001, 20001)
    gprs(b)
    assert b.at("AT+WIPCREATE=3,1,10001,1,2") == b"\r\nOK\r\n"
    (listen,) = b.last.ip
    assert listen == gw.Listen(listen.listener, "127.0.0.1", 20001)  # type: ignore[union-attr]
    lid = listen.listener  # type: ignore[union-attr]
    out = b.system.ip_event(gw.Accepted(lid, 77), b.now).line(MODEM)
    assert out == b"\r\n+WIPACCEPT: 1,1\r\n"
    assert b.at("AT+WIPDATA=2,1,1") == b"\r\nCONNECT\r\n"
    assert b.system.ip_event(gw.Received(77, b"read com speed\r"), b.now).line(MODEM) == (
        b"read com speed\r"
    )
    b.send(b"\r\n9600\r\nOK\r\n")
    assert b.last.ip == [gw.Send(77, b"\r\n9600\r\nOK\r\n")]
    assert b.system.ip_event(gw.Closed(77), b.now).line(MODEM) == b"\r\nSHUTDOWN\r\n"
    b.later(1.0)
    b.send(b"+++")
    assert b.later(1.0) == b"\r\nOK\r\n\r\n+WIPPEERCLOSE: 2,1\r\n"
    assert b.at("AT+WIPCLOSE=2,1") == b"\r\nOK\r\n"
    assert b.last.ip == []  # the peer had closed it already
    # a third client while two are allowed and one is free: index 1 again
    assert b.system.ip_event(gw.Accepted(lid, 78), b.now).line(MODEM) == (
        b"\r\n+WIPACCEPT: 1,1\r\n"
    )


def test_coverage_loss_drops_gprs() -> None:
    b = Bench()
    b.network.gateway.publish(MODEM, 10001, 20001)
    gprs(b)
    b.at("AT+WIPCREATE=3,1,10001,1,1")
    lid = b.last.ip[0].listener  # type: ignore[union-attr]
    b.system.ip_event(gw.Accepted(lid, 5), b.now)
    b.at("AT+WIPDATA=2,1,1")
    out = b.net(lambda n, t: n.set_coverage(MODEM, False, t))
    assert out.line(MODEM) == b"\r\nNO CARRIER\r\n"
    assert gw.Close(5) in out.ip and gw.Unlisten(lid) in out.ip
    assert b.at("AT+WIPBR?") == b"\r\n+WIPBR: 6,0\r\n\r\nOK\r\n"
    assert not b.network.subscriber(MODEM).attached
