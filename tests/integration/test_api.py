"""The Python API as the README and docs/python-api.md show it, and two-file raw dumps without time,
where answers are placed by address and result layout (docs/decoding.md, "Pairing where the document says nothing")."""

import analyzer
from tests.conftest import frame


def write(tmp_path, a: bytes, b: bytes):
    pa, pb = tmp_path / "a.bin", tmp_path / "b.bin"
    pa.write_bytes(a)
    pb.write_bytes(b)
    return str(pa), str(pb)


def test_readme_example(tmp_path):
    paths = write(tmp_path, frame((1, 1, 1), 0, "P?") + frame((1, 1, 1), 0, "HO"),
                  b"\x06" + frame((0, 1, 1), 1, "0FA0FC18") + b"\x15")
    bad = [(ev.number, ev.command, ev.status) for ev in analyzer.open(*paths)
           if ev.kind == "command" and ev.status != "ok"]
    assert bad == [(4, "HO", "nak")]


def test_untimed_alignment_uses_addresses(tmp_path):
    # P? to device 1 never answered; P? to device 2 answered with its position.
    # Interleaving greedily would give device 1 the ACK and leave the result orphaned.
    a = frame((1, 1, 1), 0, "P?") + frame((1, 1, 2), 0, "P?")
    b = b"\x06" + frame((0, 1, 2), 1, "0FA0FC18")
    evs = list(analyzer.open(*write(tmp_path, a, b)))
    first, second = [e for e in evs if e.kind == "command"]
    result = next(e for e in evs if e.kind == "result")
    assert first.status == "no_ack"
    assert second.status == "ok" and result.txn == second.txn


def test_untimed_alignment_retransmission_gets_the_answer(tmp_path):
    # the first copy of HO lost its ACK, the controller resent the same bytes
    ho = frame((1, 1, 1), 0, "HO")
    a = ho + ho + frame((1, 1, 1), 0, "P?")
    b = b"\x06" + b"\x06" + frame((0, 1, 1), 1, "00000000")
    cmds = [e for e in analyzer.open(*write(tmp_path, a, b)) if e.kind == "command"]
    assert [(c.status, c.retransmission) for c in cmds] == [("no_ack", False), ("ok", True), ("ok", False)]


def test_options_and_warnings(tmp_path):
    log = tmp_path / "tap.log"
    log.write_text("> 2026/11/21 08:35:52.000000000  length=2 from=0 to=1\n f8 01\n--\n")
    cap = analyzer.open(str(log), baud=19200)
    events = list(cap)
    assert cap.options.baud == 19200 and cap.timed
    assert events[0].kind == "noise" and events[0].problems[0].startswith("truncated frame")
