"""Time in socat -x -v logs: the zone the local stamps are read in, the repeated
hour of a summer-time fall-back, a clock set back, the start time known when the
log is opened, and a byte time that changes mid-log.

Expected times are worked out here from the stamps with datetime and zoneinfo."""

import itertools
import time
from datetime import UTC, datetime
from zoneinfo import ZoneInfo

import pytest

from analyzer.sources import SocatLogSource
from analyzer.sources.base import ReadSettings
from analyzer.sources.files import Input
from analyzer.sources.socatlog import open_socat_log, time_zone
from dissectors.wire import LineSettings

BT = 10 / 9600
BERLIN = ZoneInfo("Europe/Berlin")
COMMAND = bytes.fromhex("f80101010002503f94")   # 9 bytes
ACK = b"\x06"


def socat_log(chunks) -> str:
    """A log as socat 1.7.4 writes it (9-digit fraction holding microseconds), three
    lines per chunk, from ``(arrow, 'YYYY/MM/DD hh:mm:ss', microseconds, data)``."""
    out, sent = [], {">": 0, "<": 0}
    for arrow, when, micros, data in chunks:
        first = sent[arrow]
        sent[arrow] += len(data)
        out.append(f"{arrow} {when}.{micros:09d}  length={len(data)} from={first} to={sent[arrow] - 1}\n")
        out.append(f"{' ' + ' '.join(f'{b:02x}' for b in data):<49} {'.' * len(data)}\n")
        out.append("--\n")
    return "".join(out)


def header_line(chunk_index: int) -> int:
    return 3 * chunk_index + 1


def write(tmp_path, text, name="tap.log"):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def read(src):
    warnings = []
    src.report_to(warnings.append)
    return list(src.chunks()), warnings


def first_byte(when: datetime, micros: int, length: int, byte_time: float = BT) -> float:
    """Epoch of a chunk's first byte: its stamp less its length in byte times."""
    return when.timestamp() + micros / 1e6 - length * byte_time


# --- the zone ------------------------------------------------------------------

def test_utc_gives_the_absolute_start_before_any_chunk_is_read(tmp_path):
    log = socat_log([(">", "2026/11/21 08:35:52", 321418, COMMAND),
                     ("<", "2026/11/21 08:35:52", 371708, ACK)])
    src = SocatLogSource(write(tmp_path, log), BT, tz="UTC")
    start = first_byte(datetime(2026, 11, 21, 8, 35, 52, tzinfo=UTC), 321418, 9)
    assert src.start_time == pytest.approx(start, abs=1e-6)
    chunks, warnings = read(src)
    assert chunks[0].t == 0.0
    assert chunks[1].t == pytest.approx((0.371708 - BT) - (0.321418 - 9 * BT), abs=1e-9)
    assert src.start_time == pytest.approx(start, abs=1e-6)
    assert warnings == []


def test_the_opener_passes_the_zone_and_one_clock_stamps_both_lines(tmp_path):
    log = socat_log([(">", "2026/07/01 12:00:00", 0, COMMAND)])
    src = open_socat_log([Input(write(tmp_path, log))], ReadSettings(BT, tz="Asia/Tokyo"))
    # Tokyo is UTC+9 all year: noon there is 03:00 UTC
    assert src.start_time == pytest.approx(
        datetime(2026, 7, 1, 3, 0, 0, tzinfo=UTC).timestamp() - 9 * BT, abs=1e-6)
    assert src.clocks == 1
    src.close()


def test_time_zone_names():
    assert time_zone("UTC") == ZoneInfo("UTC")
    assert time_zone("Europe/Berlin") == BERLIN
    assert time_zone(None) is None   # this machine's zone
    with pytest.raises(ValueError) as e:
        time_zone("Mars/Base")
    assert str(e.value) == "unknown time zone 'Mars/Base' (give an IANA name such as Europe/Berlin or UTC)"
    for bad in ("", "/etc/passwd", "../../etc/passwd"):
        with pytest.raises(ValueError, match="unknown time zone"):
            time_zone(bad)


def test_start_time_is_learnt_from_the_first_chunk_when_the_head_does_not_tell(tmp_path, monkeypatch):
    log = socat_log([(">", "2026/11/21 08:35:52", 321418, COMMAND),
                     ("<", "2026/11/21 08:35:52", 371708, ACK)])
    monkeypatch.setattr(SocatLogSource, "_origin_in", lambda self, head, byte_time: None)
    src = SocatLogSource(write(tmp_path, log), BT, tz="UTC")
    assert src.start_time is None
    chunks, _ = read(src)
    assert chunks[0].t == 0.0
    assert src.start_time == pytest.approx(
        first_byte(datetime(2026, 11, 21, 8, 35, 52, tzinfo=UTC), 321418, 9), abs=1e-6)


def test_an_unknown_zone_is_refused_when_opening(tmp_path):
    log = socat_log([(">", "2026/07/01 12:00:00", 0, COMMAND)])
    with pytest.raises(ValueError, match="unknown time zone 'Mars/Base'"):
        SocatLogSource(write(tmp_path, log), BT, tz="Mars/Base")


# --- summer time ends ------------------------------------------------------------

# Europe/Berlin, 2026-10-25: 03:00 CEST is followed by 02:00 CET. A command just
# before, its ACK, then a retransmission 0.2 s later, stamped an hour "earlier".
FALL_BACK = [
    (">", "2026/10/25 02:59:59", 500000, COMMAND),   # CEST
    ("<", "2026/10/25 02:59:59", 900000, ACK),       # CEST
    (">", "2026/10/25 02:00:00", 100000, COMMAND),   # CET: the repeated hour
    ("<", "2026/10/25 02:00:00", 150000, ACK),
    (">", "2026/10/25 02:00:01", 0, COMMAND),
]


def fall_back_times() -> list[float]:
    """Chunk times of FALL_BACK worked out with the true offsets (fold=1: CET)."""
    def at(h, m, s, fold):
        return datetime(2026, 10, 25, h, m, s, tzinfo=BERLIN, fold=fold)
    epochs = [first_byte(at(2, 59, 59, 0), 500000, 9), first_byte(at(2, 59, 59, 0), 900000, 1),
              first_byte(at(2, 0, 0, 1), 100000, 9), first_byte(at(2, 0, 0, 1), 150000, 1),
              first_byte(at(2, 0, 1, 1), 0, 9)]
    return [e - epochs[0] for e in epochs]


@pytest.fixture
def berlin_is_local(monkeypatch):
    monkeypatch.setenv("TZ", "Europe/Berlin")
    time.tzset()
    yield
    monkeypatch.undo()
    time.tzset()


def check_fall_back(src, zone_text):
    chunks, warnings = read(src)
    ts = [c.t for c in chunks]
    assert ts == pytest.approx(fall_back_times(), abs=1e-6)
    assert all(b >= a for a, b in itertools.pairwise(ts))
    # the retransmission is 0.2 s after the ACK's stamp, less their back-dating
    assert ts[2] - ts[1] == pytest.approx(0.2 - 9 * BT + BT, abs=1e-6)
    assert warnings == [(f"{src.name}:{header_line(2)}: the clock steps back 1 h at 2026/10/25 03:00:00 "
                         f"(summer time ends in {zone_text}): read as the repeated hour")]


def test_fall_back_in_a_named_zone_is_read_as_the_repeated_hour(tmp_path):
    src = SocatLogSource(write(tmp_path, socat_log(FALL_BACK)), BT, tz="Europe/Berlin")
    check_fall_back(src, "Europe/Berlin")


def test_fall_back_in_the_local_zone_is_read_as_the_repeated_hour(tmp_path, berlin_is_local):
    src = SocatLogSource(write(tmp_path, socat_log(FALL_BACK)), BT)
    check_fall_back(src, "this machine's zone, CEST to CET")


def test_a_late_stamp_of_the_first_pass_stays_in_it(tmp_path):
    # the other direction's stamp written a little late, just after the fall-back
    log = FALL_BACK[:3] + [("<", "2026/10/25 02:59:59", 950000, ACK)] + FALL_BACK[3:]
    chunks, warnings = read(SocatLogSource(write(tmp_path, socat_log(log)), BT, tz="Europe/Berlin"))
    late = datetime(2026, 10, 25, 2, 59, 59, tzinfo=BERLIN, fold=0)
    start = first_byte(datetime(2026, 10, 25, 2, 59, 59, tzinfo=BERLIN, fold=0), 500000, 9)
    assert chunks[3].t == pytest.approx(first_byte(late, 950000, 1) - start, abs=1e-6)
    assert chunks[4].t == pytest.approx(fall_back_times()[3], abs=1e-6)
    assert len(warnings) == 1 and "summer time ends" in warnings[0]


def test_a_log_in_utc_read_in_berlin_has_no_fall_back(tmp_path):
    log = socat_log([(">", "2026/10/25 00:59:59", 500000, COMMAND),
                     (">", "2026/10/25 01:00:00", 500000, COMMAND)])
    chunks, warnings = read(SocatLogSource(write(tmp_path, log), BT, tz="UTC"))
    assert chunks[1].t == pytest.approx(1.0, abs=1e-9)
    assert warnings == []


# --- the clock set back ----------------------------------------------------------

def test_a_clock_set_back_is_said_once_and_times_follow_on(tmp_path):
    log = socat_log([
        (">", "2026/11/21 08:40:00", 0, COMMAND),
        ("<", "2026/11/21 08:40:00", 50000, ACK),
        (">", "2026/11/21 08:40:00", 500000, COMMAND),
        (">", "2026/11/21 08:39:50", 600000, COMMAND),   # NTP sets the clock back about 10 s
        ("<", "2026/11/21 08:39:50", 650000, ACK),
        (">", "2026/11/21 08:39:51", 600000, COMMAND),
    ])
    src = SocatLogSource(write(tmp_path, log), BT, tz="UTC")
    chunks, warnings = read(src)
    ts = [c.t for c in chunks]
    assert all(b >= a for a, b in itertools.pairwise(ts))
    # the stepped stamp follows on from the one before it ...
    assert ts[3] == pytest.approx(ts[2], abs=1e-9)
    # ... and the spacing after the step is kept
    assert ts[4] - ts[3] == pytest.approx((0.65 - BT) - (0.6 - 9 * BT), abs=1e-9)
    assert ts[5] - ts[3] == pytest.approx(1.0, abs=1e-9)
    assert warnings == [(f"{src.name}:{header_line(3)}: the clock steps back 9.9 s at 2026/11/21 08:39:50: "
                         f"read as following on from the time before")]


def test_several_steps_back_are_counted(tmp_path):
    log = socat_log([
        (">", "2026/11/21 08:40:00", 0, COMMAND),
        (">", "2026/11/21 08:39:50", 0, COMMAND),
        (">", "2026/11/21 08:39:55", 0, COMMAND),
        (">", "2026/11/21 08:39:45", 0, COMMAND),
    ])
    src = SocatLogSource(write(tmp_path, log), BT, tz="UTC")
    chunks, warnings = read(src)
    assert [c.t for c in chunks] == pytest.approx([0.0, 0.0, 5.0, 5.0], abs=1e-9)
    assert warnings == [(f"{src.name}: 2 steps back of the clock, later times moved forward to follow on "
                         f"(first at line {header_line(1)}: the clock steps back 10.0 s "
                         f"at 2026/11/21 08:39:50: read as following on from the time before)")]


def test_jitter_between_the_directions_is_left_alone(tmp_path):
    log = socat_log([(">", "2026/11/21 08:40:00", 500000, COMMAND),
                     ("<", "2026/11/21 08:40:00", 200000, ACK),      # 0.3 s behind: jitter
                     (">", "2026/11/21 08:40:01", 0, COMMAND)])
    chunks, warnings = read(SocatLogSource(write(tmp_path, log), BT, tz="UTC"))
    assert [c.t for c in chunks] == pytest.approx(
        [0.0, (0.2 - BT) - (0.5 - 9 * BT), 1.0 - 0.5], abs=1e-9)
    assert warnings == []


# --- byte time -------------------------------------------------------------------

def test_a_new_byte_time_back_dates_later_chunks_only(tmp_path):
    log = socat_log([(">", "2026/11/21 08:40:00", 100000, COMMAND),
                     ("<", "2026/11/21 08:40:00", 200000, ACK),
                     (">", "2026/11/21 08:40:01", 0, COMMAND)])
    src = SocatLogSource(write(tmp_path, log), BT, tz="UTC")
    lines = {line: LineSettings(9600) for line in src.lines}   # what a capture gives it
    src.read_with(lines)
    chunks = src.chunks()
    first = next(chunks)
    fast = 10 / 115200   # the link switched to 115200 baud after the first command
    for settings in lines.values():
        settings.set_rate(115200)
    rest = list(chunks)
    assert first.t == 0.0
    origin = 0.1 - 9 * BT   # t = 0 keeps the byte time the log was opened with
    assert rest[0].t == pytest.approx((0.2 - fast) - origin, abs=1e-9)
    assert rest[1].t == pytest.approx((1.0 - 9 * fast) - origin, abs=1e-9)
