"""Messages (§6.14) carried by the modem driver as SMS, end to end on a stepped clock: the
message logic fills the outbox, the driver sends through the modem and the network, and
``read record N from lastread shift`` moves its point only after a delivery (§6.8.4.1)."""

from __future__ import annotations

from gsm_world import LOGGER, PHONE, World

SETUP = (
    "write command 1 name /data/",
    "write command 1 value/read record 10 from lastread shift/",
    f"write address 1 type sms write address 1 value {PHONE}",
    "write message 1 address 1 write message 1 command 1",
)


def test_a_message_goes_by_sms_and_moves_lastread_only_when_delivered() -> None:
    w = World("wavecom41", *SETUP)
    w.run(5)
    w.ask("write text /first/")
    w.ask("write message 1 run 1")
    w.run(10)
    first = w.sms_to(PHONE)
    assert len(first) == 1 and ",3,/first/\r\n" in first[0] and first[0].endswith("OK\r\n")
    # delivered: the next sending starts after the rows already sent
    w.ask("write text /second/")
    w.ask("write message 1 run 1")
    w.run(10)
    second = w.sms_to(PHONE)[1:]
    assert len(second) == 1 and "/second/" in second[0] and "/first/" not in second[0]


def test_an_undelivered_message_sends_its_rows_again_with_the_next() -> None:
    w = World("wavecom41", *SETUP)
    w.run(5)
    w.collect(w.site.network_call(lambda n: n.set_coverage(LOGGER, False, w.now), w.now))
    w.ask("write text /kept/")
    w.ask("write message 1 run 1")
    w.run(90)
    assert w.sms_to(PHONE) == []  # no coverage: not delivered, the point stays
    w.collect(w.site.network_call(lambda n: n.set_coverage(LOGGER, True, w.now), w.now))
    w.ask("write text /later/")
    w.ask("write message 1 run 1")
    w.run(30)
    texts = w.sms_to(PHONE)
    assert len(texts) == 1 and "/kept/" in texts[0] and "/later/" in texts[0]


def test_a_ring_from_a_ringvoice_number_runs_its_message() -> None:
    w = World(
        "wavecom41", *SETUP, f"write address 2 type ringvoice 1 write address 2 value {PHONE}"
    )
    w.run(5)
    w.ask("write text /rang/")
    w.call("voice")
    w.run(30)
    texts = w.sms_to(PHONE)
    assert len(texts) == 1 and "/rang/" in texts[0]
