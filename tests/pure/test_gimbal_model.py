"""The simulated gimbal answers as the spec says (values worked out from the tables)."""

from analyzer.simulation.gimbal import Faults, GimbalModel
from dissectors import Deframer
from dissectors.event import Event
from tests.conftest import frame


def command(payload: str, dst=(1, 1, 1), src=0, corrupt=False) -> Event:
    raw = bytearray(frame(dst, src, payload))
    if corrupt:
        raw[-1] ^= 0x01
    d = Deframer("A")
    (ev,) = d.feed(bytes(raw)) + d.finish()
    return ev


def answers(model, payload, now=0.0, **kw):
    """(simple bytes, result payload or None, result header) of one command."""
    replies = model.handle(command(payload, **kw), now)
    simple = replies[0].data if replies else b""
    if len(replies) > 1:
        evs = Deframer("B").feed(replies[1].data)
        return simple, evs[0].payload.decode(), (evs[0].dst, evs[0].src), replies[1].at
    return simple, None, None, None


def test_position_query_and_go_to_at_the_set_rate():
    g = GimbalModel((1, 1, 1), answer_delay=0.0)
    assert answers(g, "P?")[:2] == (b"\x06", "00000000")
    assert answers(g, "RP03E8")[0] == b"\x06"                 # 0x03E8 = 1000 -> 10.00 deg/s pan
    assert answers(g, "P0FA0FC18")[:2] == (b"\x06", None)     # go to +40.00, -10.00
    g.update(1.0)                                              # 1 s at 10 deg/s both axes
    assert (g.az, g.el) == (10.0, -10.0)
    g.update(5.0)
    # result of P?: +40.00 = 0x0FA0, -10.00 = 0xFC18 (Table 15)
    assert answers(g, "P?", now=5.0)[1] == "0FA0FC18"


def test_result_address_is_swapped_per_table3():
    g = GimbalModel((5, 1, 12))
    _, _payload, (dst, src), _ = answers(g, "P?", dst=(5, 1, 12), src=2)
    assert dst == (2, 1, 12) and src == 5


def test_nak_on_bad_checksum_and_nic_for_what_it_does_not_implement():
    g = GimbalModel((1, 1, 1))
    assert answers(g, "HO", corrupt=True)[0] == b"\x15"
    assert answers(g, "FA")[0] == b"\x06?"          # Table 16: auto-focus "Not Implemented"
    assert answers(g, "QX")[0] == b"\x06?"          # not in the document
    assert answers(g, "L0")[0] == b"\x06?"          # reserved relay


def test_queries_follow_the_tables():
    g = GimbalModel((1, 1, 7), name="PTG", serial="SN42")
    assert answers(g, "GRP0F")[0] == b"\x06"         # 1.5
    assert answers(g, "GRT13")[0] == b"\x06"         # 1.9
    assert answers(g, "G?")[1] == "G?0F130000"       # Table 8
    assert answers(g, "D?", dst=(1, 1, 7))[1] == "07 9" + "PTG".ljust(20) + "SN42".ljust(20)   # Table 6
    assert answers(g, "AW")[1] == "0"               # Table 5: all fine
    assert answers(g, "B?")[1] == "C7"              # 115200
    assert answers(g, "LA")[0] == b"\x06" and answers(g, "LB")[0] == b"\x06"
    assert answers(g, "LR")[1] == "LC"              # relays 2 and 3 closed (Table 4A)
    assert answers(g, "LS7FF8003E80FA")[0] == b"\x06"
    assert answers(g, "L?")[1] == "7FF8003E80FA"    # Table 10
    assert answers(g, "V4BF123")[0] == b"\x06"
    assert answers(g, "V?")[1] == "4BF123"          # Table 17


def test_presets_store_and_recall():
    g = GimbalModel((1, 1, 1))
    g.az, g.el = 12.34, -5.0
    assert answers(g, "S0A")[0] == b"\x06"
    assert answers(g, "S?0A")[1] == "04D2FE0C"      # 1234 = 0x04D2, -500 = 0xFE0C
    g.az = g.el = 0.0
    answers(g, "P0A")
    assert g.target == (12.34, -5.0)


def test_initialisation_takes_seconds():
    g = GimbalModel((1, 1, 1), init_seconds=3.0, answer_delay=0.002)
    simple, payload, _, at = answers(g, "IX", now=10.0)
    assert simple == b"\x06" and payload == "09090909"
    assert at >= 13.0


def test_wildcards_and_other_addresses():
    g = GimbalModel((1, 2, 3))
    assert g.addressed(command("P?", dst=(255, 255, 255)))
    assert g.addressed(command("P?", dst=(1, 2, 255)))
    assert not g.addressed(command("P?", dst=(1, 2, 4)))


def test_dropped_acks_fault():
    g = GimbalModel((1, 1, 1), faults=Faults(drop_ack=1.0))
    assert g.handle(command("HO"), 0.0) == []
