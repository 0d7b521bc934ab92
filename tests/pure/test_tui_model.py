"""The TUI's model without Textual: rows, filter, pairing index, navigation,
statistics, replay playback, timeline layout."""

import pytest

import analyzer
from analyzer.analysis.filter import FilterError
from analyzer.tui.model import CaptureModel, hex_lines
from analyzer.tui.timeline import layout
from tests.tui_fixtures import write_capture


@pytest.fixture
def loaded(tmp_path):
    path = tmp_path / "tap.log"
    expected = write_capture(path)
    model = CaptureModel(follow=False)
    events = list(analyzer.open(str(path)))
    model.extend(events[:5])      # batches, as the feed delivers them
    model.extend(events[5:])
    return model, expected


def test_rows_are_the_events_in_wire_order(loaded):
    model, expected = loaded
    assert model.row_count == len(expected["kinds"])
    assert [model.row(i).kind for i in range(model.row_count)] == expected["kinds"]
    assert [model.row(i).number for i in range(model.row_count)] == list(range(1, 14))
    assert model.row(model.row_count) is None


def test_pairing_index_and_detail_links(loaded):
    model, expected = loaded
    assert model.nav.answers == expected["answers"]
    for number, status in expected["status"].items():
        assert model.event(number).status == status
    assert model.nav.partner(1) == 2 and model.nav.partner(3) == 1 and model.nav.partner(11) is None
    labels = [n.label for node in model.detail(model.event(1)) for n in [node, *node.children]]
    assert any(label.startswith("ACK in #2 after") for label in labels)
    assert any(label.startswith("result in #3 after") for label in labels)
    result = model.detail(model.event(3))
    pairing = next(n for n in result if n.label == "pairing")
    assert pairing.children[0].jump == 1 and pairing.children[0].label.startswith("answers #1")
    fields = next(n for n in result if n.label.startswith("P?"))
    # Table 15: az 0x03E8 = 1000 hundredths = 10.00 deg, el 0xFE0C = -500 = -5.00 deg,
    # at payload bytes 0-3 and 4-7, i.e. frame bytes 6-9 and 10-13
    assert [(c.label.split("  ")[0], c.span) for c in fields.children] == [
        ("azimuth_deg = 10.0 deg", (6, 10)), ("elevation_deg = -5.0 deg", (10, 14))]


def test_filter_view_and_bad_filter(loaded):
    model, _ = loaded
    model.set_filter('kind == "command"')
    assert [model.row(i).number for i in range(model.row_count)] == [1, 4, 6, 8, 11, 12]
    assert model.row_of(6) == 2 and model.row_of(7) is None
    assert model.nearest_row(7) == 3       # the next shown event
    with pytest.raises(FilterError) as e:
        model.set_filter('kind == "comand"')
    assert e.value.column > 0
    assert model.filter_text == 'kind == "command"'   # a bad filter leaves the view alone
    model.set_filter("")
    assert model.row_count == 13
    assert model.filter.history == ['kind == "command"']


def test_filter_applies_to_events_arriving_later(tmp_path):
    path = tmp_path / "tap.log"
    write_capture(path)
    events = list(analyzer.open(str(path)))
    model = CaptureModel()
    model.set_filter('status == "nak"')
    model.extend(events[:4])
    assert model.row_count == 1
    model.extend(events[4:])
    assert [model.row(i).number for i in range(model.row_count)] == [4]


def test_error_navigation_both_ways_and_under_a_filter(loaded):
    model, expected = loaded
    errs = expected["errors"]
    seen, at = [], 0
    while (at := model.nav.next_error(at)) is not None:
        seen.append(at)
    assert seen == errs
    assert model.nav.next_error(13, forward=False) == errs[-1]
    assert model.nav.next_error(4, forward=False) is None
    model.set_filter('line == "B"')
    assert model.nav.next_error(0) == 5


def test_same_device_marks_and_search(loaded):
    model, _ = loaded
    # 1.1.1: P? (#1) and its answers #2 #3, then FA (#8) and its answers #9 #10
    assert model.nav.same_device(1) == 2 and model.nav.same_device(3) == 8 and model.nav.same_device(10) is None
    assert model.nav.same_device(8, forward=False) == 3
    model.marks.toggle(6)
    model.marks.toggle(12)
    assert model.nav.next_mark(0) == 6 and model.nav.next_mark(6) == 12 and model.nav.next_mark(12) == 6
    assert model.marks.toggle(6) is False and model.nav.next_mark(0) == 12
    assert model.nav.search("NIC", 0) == 8 and model.nav.search("NIC", 8) == 10   # its status, then the NIC row
    assert model.nav.search("go to az", 5) == 6 and model.nav.search("go to az", 6) == 4   # wraps round


def test_time_modes(loaded):
    model, _ = loaded
    e1, e2 = model.event(1), model.event(2)
    assert model.text.time_text(e2, 1) == f"{e2.t:.6f}"
    model.text.cycle_time_mode()
    assert model.text.time_mode == "relative" and model.text.time_text(e2, 1) == f"+{e2.t - e1.t:.6f}"
    model.text.cycle_time_mode()
    assert model.text.time_mode == "delta" and model.text.time_text(e2, 1) == f"+{e2.t - e1.t:.6f}"
    assert model.text.time_text(model.event(3), 2) == f"+{model.event(3).t - e2.t:.6f}"
    model.text.cycle_time_mode()
    assert model.text.time_mode == "absolute"


def test_statistics_and_device_map(loaded):
    model, _ = loaded
    d = model.totals.stats.to_dict()
    assert d["commands"] == 6 and d["status"]["nak"] == 1 and d["status"]["nic"] == 1
    assert d["checksum_errors"] == 1 and d["retransmissions"] == 2
    assert model.totals.devices["1.1.1"].nic == {"FA"}
    assert model.totals.devices["1.1.3"].commands == 2 and model.totals.devices["1.1.3"].answered == 1
    assert model.totals.devices["1.1.2"].lines == {"B"}
    # plots: the go-to commanded 20.00/15.00 deg to 1.1.2 (twice); 1.1.1 reported 10/-5
    assert model.series["1.1.2"]["commanded azimuth"][0][1] == 20.0
    assert model.series["1.1.2"]["commanded elevation"][0][1] == 15.0
    assert model.series["1.1.1"]["reported azimuth"][0][1] == 10.0


def test_follow_and_new_badge(loaded):
    model, _ = loaded
    model.follow = True
    model.following.stop()
    assert not model.follow and model.new_while_away == 0
    model.extend([])
    events = list(model.events)
    extra = CaptureModel()
    extra.follow = True
    extra.extend(events[:3])
    extra.following.stop()
    extra.extend(events[3:6])
    assert extra.new_while_away == 3
    extra.following.resume()
    assert extra.follow and extra.new_while_away == 0


def test_unsettled_rows_show_after_settled_ones(loaded):
    model, _ = loaded
    events = model.events
    m = CaptureModel()
    m.extend(events[:10])
    m.set_unsettled(events[10:])
    assert m.row_count == 13 and m.row(12).number == 13 and m.row_of(12) == 11
    m.set_filter('kind == "ack"')
    assert [m.row(i).number for i in range(m.row_count)] == [2, 7, 9, 13]


def test_replay_playback_shows_events_up_to_the_position(loaded):
    done, _ = loaded
    t = [e.t for e in done.events]
    model = CaptureModel()
    model.replay.start(speed=1.0)
    model.add(done.events[:7], [])         # the file loads ahead of the playback
    model.add(done.events[7:], [])
    assert model.row_count == 0
    model.replay.advance(100.0)         # starts at the first event
    assert model.row_count == 1
    model.replay.advance(100.0 + (t[2] - t[0]) + 1e-6)   # one wall second = one capture second
    assert model.row_count == 3
    assert model.totals.stats.to_dict()["commands"] == 1          # statistics follow the position
    model.replay.playback.playing = False
    model.replay.advance(200.0)
    assert model.row_count == 3
    model.replay.seek(10.0)                      # past the end: clamps to the last event
    assert model.row_count == 13 and model.totals.stats.to_dict()["status"]["nak"] == 1
    model.replay.seek(-(t[-1] - t[3]))           # back: to event 4 (the NAK'd go-to)
    assert model.row_count == 4 and model.nav.answers == {1: [2, 3]}
    # #4 shows its final status (nak) before its NAK is played: a replay shows
    # events as decoded from the whole file
    assert model.totals.stats.to_dict()["commands"] == 2 and model.nav.next_error(0) == 4 and model.nav.next_error(4) is None
    model.replay.playback.speed = 0              # max: everything
    model.replay.advance(201.0)
    assert model.row_count == 13 and model.nav.next_error(4) == 5


def test_a_replay_played_to_the_end_of_its_file_stops_there(loaded):
    done, _ = loaded
    t = [e.t for e in done.events]
    model = CaptureModel()
    model.replay.start(speed=1.0)
    model.add(done.events, [])
    model.replay.advance(100.0)
    model.replay.advance(100.0 + (t[-1] - t[0]) + 5.0)   # past the last event, the file still loading
    assert model.row_count == 13 and model.replay.playback.playing
    model.done = True                                    # the file has ended
    model.replay.advance(110.0 + (t[-1] - t[0]))
    assert not model.replay.playback.playing and model.replay.position == t[-1]
    model.replay.playback.toggle(120.0 + (t[-1] - t[0]))   # play again: from the end, it stops again
    model.replay.advance(121.0 + (t[-1] - t[0]))
    assert not model.replay.playback.playing and model.row_count == 13
    # a minute later: back to the third event and play: on from there, the pause not counted
    model.replay.seek(-(t[-1] - t[2]))
    model.replay.playback.toggle(200.0)
    model.replay.advance(200.0 + (t[3] - t[2]) + 1e-6)
    assert model.row_count == 4 and model.replay.playback.playing


def test_timeline_links_command_to_answers():
    from dissectors.event import ACK, COMMAND, Event

    cmd = Event("A", 0, COMMAND, b"\xf8" * 9, 0.0, 0.009)
    cmd.number, cmd.txn = 1, 1
    ack = Event("B", 0, ACK, b"\x06", 0.014, 0.015)
    ack.number, ack.txn, ack.request = 2, 1, 1
    rows = layout([cmd, ack], start=0.0, scale=0.001, width=30, selected=None, style_of=lambda e: "")
    axis, upper, links, lower = (r.text for r in rows)
    assert upper.startswith("█" * 9 + " ")          # 9 ms of command at 1 ms a column
    assert lower[14] == "▌" and lower[:14].strip() == ""
    assert links[9] == "└" and links[10:14] == "────" and links[14] == "┐"
    assert axis.startswith("│0.000")


def test_hex_lines_highlight_a_field():
    raw = bytes(range(20))
    lines = hex_lines(raw, highlight=(14, 18), width=16)
    assert lines[0][1].startswith("00 01 02") and lines[1][0] == "0010"
    assert lines[0][3] == [(42, 47)]       # bytes 14-15: "0e 0f", columns [42, 47) of "00 01 ... 0f"
    assert lines[1][3] == [(0, 5)]         # bytes 16-17: "10 11"


def test_device_filter_detail_and_navigation_use_the_answers_device(loaded):
    model, _ = loaded
    # 1.1.3: HO with a bad checksum (#11, unanswered), HO again (#12) and its ACK (#13)
    model.set_filter('device == "1.1.3"')
    assert [model.row(i).number for i in range(model.row_count)] == [11, 12, 13]
    # 1.1.2: the go-to (#4) and its NAK (#5), sent again (#6) and ACKed (#7)
    model.set_filter('device == "1.1.2"')
    assert [model.row(i).number for i in range(model.row_count)] == [4, 5, 6, 7]
    assert model.nav.same_device(5) == 6 and model.nav.same_device(7) is None
    assert model.text.cells(model.event(5), 1)[3] == "1.1.2"     # the device column of a NAK
    model.set_filter("")
    head = model.detail(model.event(13))[0]
    device = [n for n in head.children if n.label.startswith("device ")]
    assert [(n.label.split(" (")[0], n.jump) for n in device] == [("device 1.1.3", 12)]
    # a result's header addresses the controller (0.1.1); its device is 1.1.1
    labels = [n.label for n in model.detail(model.event(3))[0].children]
    assert "address 0.1.1 (group.port.device)" in labels
    assert any(label.startswith("device 1.1.1 ") for label in labels)
