"""Pairing per §1.4.2-1.4.3, Table 3 and docs/decoding.md ("Pairing"): statuses, latency,
timeouts, retransmissions, addresses. Events are built by hand with times chosen
so that latencies are easy to check."""

from analyzer.analysis.pairing import Pairer, Timeouts
from dissectors.event import Event

BT = 0.001  # one byte per millisecond keeps the arithmetic readable


def frame_ev(line, kind, dst, src, payload: bytes, t: float) -> Event:
    body = bytes([*dst, src, len(payload)]) + payload
    raw = b"\xf8" + body + bytes([sum(body) & 0xFF])
    ev = Event(line, 0, kind, raw, t, t + len(raw) * BT)
    ev.dst, ev.src, ev.payload, ev.checksum_ok = tuple(dst), src, payload, True
    return ev


def cmd(payload, t, dst=(1, 1, 1), src=0, line="A"):
    return frame_ev(line, "command" if line != "AB" else "frame", dst, src, payload, t)


def res(payload, t, dst=(0, 1, 1), src=1, line="B"):
    return frame_ev(line, "result" if line != "AB" else "frame", dst, src, payload, t)


def simple(kind, t, line="B"):
    return Event(line, 0, kind, {"ack": b"\x06", "nak": b"\x15", "nic": b"?"}[kind], t, t + BT)


def run(events, **timeouts):
    p = Pairer(Timeouts(**timeouts))
    out = []
    for ev in events:
        out += p.push(ev)
    return out + p.finish()


def test_ack_only_command_is_ok_with_latency():
    # command: 2 payload bytes + 7 = 9 bytes from t=0 -> ends at 0.009; ACK at 0.0132
    c = cmd(b"HO", 0.0)
    a = simple("ack", 0.0132)
    out = run([c, a])
    assert [e.number for e in out] == [1, 2]
    assert c.status == "ok" and c.txn == a.txn == 1
    assert abs(a.latency - 0.0042) < 1e-9 and a.request == 1


def test_query_with_result_is_ok_and_result_is_decoded():
    c = cmd(b"P?", 0.0)                       # ends 0.009
    a = simple("ack", 0.010)
    r = res(b"0FA0FC18", 0.012)
    run([c, a, r])
    assert c.status == "ok"
    assert r.command == "P?" and r.txn == c.txn and r.request == c.number
    assert r.fields == {"azimuth_deg": 40.0, "elevation_deg": -10.0}
    assert abs(r.latency - 0.003) < 1e-9


def test_nak():
    c, n = cmd(b"HO", 0.0), simple("nak", 0.010)
    run([c, n])
    assert c.status == "nak" and n.txn == c.txn


def test_nic_follows_ack():
    c, a, q = cmd(b"QX", 0.0), simple("ack", 0.010), simple("nic", 0.011)
    run([c, a, q])
    assert c.status == "nic" and q.txn == c.txn
    assert any(p.startswith("unknown command") for p in c.problems)


def test_nic_for_a_query_cancels_the_result():
    c, a, q = cmd(b"V?", 0.0), simple("ack", 0.010), simple("nic", 0.011)
    nxt = cmd(b"HO", 5.0)
    run([c, a, q, nxt, simple("ack", 5.02)])
    assert c.status == "nic"


def test_new_command_before_ack_means_no_ack_whatever_the_timeout():
    c1, c2, a = cmd(b"HO", 0.0), cmd(b"PL", 0.012), simple("ack", 0.030)
    run([c1, c2, a], ack=10.0)
    assert c1.status == "no_ack" and c2.status == "ok" and a.txn == c2.txn
    assert c1.problems[0].startswith("unanswered")


def test_no_ack_by_timeout_and_late_answer():
    c = cmd(b"HO", 0.0)                       # ends 0.009; ack timeout 0.1 -> deadline 0.109
    late = simple("ack", 0.5)
    run([c, late], ack=0.1)
    assert c.status == "no_ack"
    assert late.txn == c.txn and late.problems[0].startswith("late answer")


def test_no_result_by_timeout():
    c, a = cmd(b"P?", 0.0), simple("ack", 0.010)
    later = cmd(b"HO", 3.0)
    run([c, a, later, simple("ack", 3.02)], result=1.0)
    assert c.status == "no_result"
    assert any(p.startswith("missing result") for p in c.problems)


def test_ix_waits_longer_by_default():
    # IX (initialisation) takes seconds: a result 20 s later still answers it
    c, a, r = cmd(b"IX", 0.0), simple("ack", 0.010), res(b"09090909", 20.0)
    run([c, a, r])
    assert c.status == "ok" and r.command == "IX"


def test_per_command_timeout_override():
    c, a, r = cmd(b"IX", 0.0), simple("ack", 0.010), res(b"09090909", 20.0)
    run([c, a, r], result_by_command={"IX": 5.0})
    assert c.status == "no_result" and r.txn is None


def test_pending_at_capture_end():
    c1 = cmd(b"HO", 0.0)
    c2, a2 = cmd(b"P?", 1.0), simple("ack", 1.010)
    run([c2, a2])
    run([c1])
    assert c1.status == "pending" and c2.status == "pending"


def test_retransmission_after_nak_and_after_timeout():
    c1, n1 = cmd(b"HO", 0.0), simple("nak", 0.010)
    c2, a2 = cmd(b"HO", 0.050), simple("ack", 0.060)
    c3 = cmd(b"PL", 1.0)
    c4, a4 = cmd(b"PL", 2.0), simple("ack", 2.010)    # c3 timed out
    c5, a5 = cmd(b"PL", 3.0), simple("ack", 3.010)    # c4 was fine: a repeat, not a retransmission
    run([c1, n1, c2, a2, c3, c4, a4, c5, a5], ack=0.2)
    assert c2.retransmission and c4.retransmission
    assert not c1.retransmission and not c5.retransmission
    assert c2.problems == ["retransmission: repeats #1 after nak"]


def test_result_address_groups_swapped_table3():
    # Table 3: command to group 5, port 1, device 12 from GCU 2; result to 2, 1, 12 from 5
    c = cmd(b"P?", 0.0, dst=(5, 1, 12), src=2)
    a = simple("ack", 0.010)
    wrong = res(b"00000000", 0.012, dst=(5, 1, 12), src=2)  # not swapped: not an answer
    right = res(b"0FA00000", 0.030, dst=(2, 1, 12), src=5)
    run([c, a, wrong, right])
    assert wrong.txn is None and wrong.problems[0].startswith("orphan")
    assert right.txn == c.txn and right.fields["azimuth_deg"] == 40.0


def test_several_devices_on_one_port_results_go_by_address_and_layout():
    # IX to device 2 (slow), then V? to device 3; V?'s result comes first, IX's later
    ix = cmd(b"IX", 0.0, dst=(1, 1, 2))
    a1 = simple("ack", 0.010)
    v = cmd(b"V?", 0.1, dst=(1, 1, 3))
    a2 = simple("ack", 0.110)
    rv = res(b"4BF123", 0.12, dst=(0, 1, 3))
    rix = res(b"09090909", 4.0, dst=(0, 1, 2))
    run([ix, a1, v, a2, rv, rix])
    assert rv.command == "V?" and rv.txn == v.txn and rv.fields == {"zoom": 1215, "focus": 291}
    assert rix.command == "IX" and rix.txn == ix.txn
    assert ix.status == v.status == "ok"


def test_layout_decides_between_two_waiting_commands_on_one_device():
    aw = cmd(b"AW", 0.0)
    a1 = simple("ack", 0.010)
    ix = cmd(b"IX", 0.05)
    a2 = simple("ack", 0.06)
    r_aw = res(b"3", 0.07)          # one hex digit: an AW status, not an IX report
    run([aw, a1, ix, a2, r_aw, res(b"09090909", 3.0)])
    assert r_aw.command == "AW" and r_aw.txn == aw.txn


def test_wildcard_address_is_answered_by_the_device():
    c = cmd(b"D?", 0.0, dst=(255, 255, 255), src=0)
    a = simple("ack", 0.010)
    r = res(b"01 9" + b"PTG".ljust(20) + b"SN1".ljust(20), 0.02, dst=(0, 3, 7), src=4)
    run([c, a, r])
    assert r.txn == c.txn and r.fields["name"] == "PTG"


def test_orphans():
    a = simple("ack", 0.0)
    q = simple("nic", 0.1)
    r = res(b"0FA0FC18", 0.2)
    run([a, q, r])
    assert all(e.txn is None and e.problems[0].startswith("orphan") for e in (a, q, r))


def test_output_keeps_wire_order_and_numbers():
    evs = [cmd(b"P?", 0.0), simple("ack", 0.01), cmd(b"HO", 0.05), simple("ack", 0.06),
           res(b"0FA0FC18", 0.07)]
    out = run(evs)
    assert out == evs and [e.number for e in out] == [1, 2, 3, 4, 5]


def test_memory_stays_flat_when_results_never_come():
    p = Pairer(Timeouts(result=0.5))
    most_held = 0
    for k in range(20000):
        t = k * 0.05
        p.push(cmd(b"P?", t))
        p.push(simple("ack", t + 0.01))
        most_held = max(most_held, len(p.held()))   # a command awaiting its result is held
    assert most_held < 50


def test_single_line_frames_are_classified():
    # one wire: command from group 0 to 1.1.1, ACK, result back from group 1
    c = cmd(b"P?", 0.0, line="AB")
    a = simple("ack", 0.01, line="AB")
    r = res(b"P0FA0FC18", 0.012, line="AB")     # parses as a P command too, but answers P?
    u = cmd(b"QX", 0.1, line="AB")              # unknown, but travels like a command
    run([c, a, r, u, simple("ack", 0.12, line="AB"), simple("nic", 0.121, line="AB")])
    assert (c.kind, r.kind, u.kind) == ("command", "result", "command")
    assert r.command == "P?" and r.fields["elevation_deg"] == -10.0
    assert u.status == "nic"


def test_nic_must_follow_the_ack_directly():
    # a '?' byte after a result or after noise is not the device's NIC (§1.4.2)
    c, a, r = cmd(b"V?", 0.0), simple("ack", 0.010), res(b"4BF123", 0.012)
    late_q = simple("nic", 0.05)
    c2, a2 = cmd(b"PS", 1.0), simple("ack", 1.01)
    noise = Event("B", 0, "noise", b"\xf8\x01", 1.02, 1.022)
    q2 = simple("nic", 1.03)
    run([c, a, r, late_q, c2, a2, noise, q2])
    assert c.status == "ok" and c2.status == "ok"
    assert late_q.txn is None and q2.txn is None
    assert late_q.problems[0].startswith("orphan") and q2.problems[0].startswith("orphan")


def test_answers_belong_to_their_commands_device():
    # An ACK, NAK or NIC carries no address: it is the device of the command it
    # answers. A result's header names the controller as destination and the
    # device by source group, port and device (Table 3): 2.1.12 from 5 is 5.1.12.
    q, a_q = cmd(b"P?", 0.0, dst=(5, 1, 12), src=2), simple("ack", 0.010)
    r_q = res(b"0FA00000", 0.012, dst=(2, 1, 12), src=5)
    h, n_h = cmd(b"HO", 0.1, dst=(1, 1, 3)), simple("nak", 0.110)
    f, a_f, nic = cmd(b"FA", 0.2, dst=(1, 2, 4)), simple("ack", 0.210), simple("nic", 0.211)
    run([q, a_q, r_q, h, n_h, f, a_f, nic])
    assert [e.device for e in (q, a_q, r_q)] == ["5.1.12"] * 3
    assert [e.device for e in (h, n_h)] == ["1.1.3"] * 2
    assert [e.device for e in (f, a_f, nic)] == ["1.2.4"] * 3
    assert r_q.dst == (2, 1, 12)          # the header stays as it was on the wire
    assert a_q.to_dict()["device"] == "5.1.12" and a_q.to_dict()["dst"] is None


def test_a_late_ack_still_names_the_device_and_orphans_none():
    c = cmd(b"HO", 0.0, dst=(1, 1, 7))          # ends 0.009; ack timeout 0.1
    late = simple("ack", 0.5)
    orphan = simple("ack", 0.6)
    noise = Event("B", 0, "noise", b"\x7e\xe0", 0.7, 0.702)
    run([c, late, orphan, noise], ack=0.1)
    assert late.device == "1.1.7"
    assert orphan.device is None and noise.device is None
    assert orphan.to_dict()["device"] is None


def test_untimed_command_waits_behind_a_bounded_number_of_events():
    """Without time nothing times out, and a noise flood has no later commands to
    count: a P? whose ACK came but whose result never does must not hold every
    later event until the end of the capture (memory grew with the file)."""
    body = bytes([1, 1, 1, 0, 2]) + b"P?"
    p_query = Event("A", 0, "command", b"\xf8" + body + bytes([sum(body) & 0xFF]))
    p_query.dst, p_query.src, p_query.payload, p_query.checksum_ok = (1, 1, 1), 0, b"P?", True
    ack = Event("B", 0, "ack", b"\x06")
    limit = 100
    pairer = Pairer(Timeouts(untimed_hold=limit))
    out = pairer.push(p_query) + pairer.push(ack)
    most_held = 0
    for k in range(5 * limit):
        out += pairer.push(Event("B", k, "noise", b"\x00"))
        most_held = max(most_held, len(pairer.held()))
    assert most_held <= limit + 1
    assert p_query in out and p_query.status == "no_result"
    assert any(pr == f"missing result: none within the next {limit} events" for pr in p_query.problems)
    out += pairer.finish()
    assert [e.number for e in out] == list(range(1, 5 * limit + 3))   # nothing lost, in order
