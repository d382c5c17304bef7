"""Nothing is lost (gsm.md §3, issue 12 "faults"): whatever the radio, the coverage and the
modem's store do, every SMS sent to the modem reaches it exactly once, in order."""

from __future__ import annotations

from gsm_helpers import MODEM, PHONE, Bench
from hypothesis import given, settings
from hypothesis import strategies as st

ACTIONS = st.lists(
    st.sampled_from(
        [
            "sms",
            "sms",
            "sms",
            "radio off",
            "radio on",
            "cover off",
            "cover on",
            "delete",
            "read",
            "tick",
        ]
    ),
    max_size=40,
)


@settings(max_examples=60, deadline=None)
@given(ACTIONS, st.integers(1, 4))
def test_every_sms_arrives_once_in_order(actions: list[str], store_size: int) -> None:
    b = Bench(store_size=store_size)
    b.at("AT+CMGF=1")
    sent: list[str] = []
    for action in actions:
        if action == "sms":
            sent.append(f"m{len(sent)}")
            b.net(lambda n, t: n.phone_sms(PHONE, MODEM, sent[-1], t))
        elif action.startswith("radio"):
            b.at(f"AT+CFUN={int(action.endswith('on'))}")
        elif action.startswith("cover"):
            covered = action.endswith("on")
            b.net(lambda n, t: n.set_coverage(MODEM, covered, t))  # noqa: B023
        elif action == "delete":
            b.at("AT+CMGD=1,4")
        elif action == "read":
            b.at('AT+CMGL="ALL"')
        else:
            b.later(30)
    # recovery: radio on, coverage back, the store emptied as often as needed
    b.at("AT+CFUN=1")
    b.net(lambda n, t: n.set_coverage(MODEM, True, t))
    received = [s.text for s in b.network.delivered(MODEM)]
    for _ in range(len(sent) + 1):
        b.at("AT+CMGD=1,4")
    assert [s.text for s in b.network.delivered(MODEM)] == sent
    assert b.network.queued(MODEM) == []
    assert received == sent[: len(received)]
