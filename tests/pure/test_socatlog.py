"""Reading socat -x -v logs exactly as Debian's socat 1.7.4 writes them: a 9-digit
fraction that holds microseconds, hex in the first 49 columns."""

import textwrap

import pytest

from analyzer.sources import CaptureError, SocatLogSource, detect

BT = 10 / 9600

# Shaped like the log socat 1.7.4.4 wrote here between two ptys (a P? command,
# an ACK 50.29 ms later, a result frame 3.2 ms after that).
LOG = textwrap.dedent("""\
    > 2026/11/21 08:35:52.000321418  length=9 from=0 to=8
     f8 01 01 01 00 02 50 3f 94                       ......P?.
    --
    < 2026/11/21 08:35:52.000371708  length=1 from=0 to=0
     06                                               .
    --
    < 2026/11/21 08:35:52.000374893  length=16 from=1 to=16
     f8 00 01 01 01 09 50 30 46 41 30 46 43 31 38 00  ......P0FA0FC18.
    --
    """)


def write(tmp_path, text, name="tap.log"):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def test_fraction_is_microseconds_and_first_byte_time_is_estimated(tmp_path):
    src = SocatLogSource(write(tmp_path, LOG), BT)
    chunks = list(src.chunks())
    assert [(c.line, c.data.hex()) for c in chunks] == [
        ("A", "f80101010002503f94"), ("B", "06"), ("B", "f8000101010950304641304643313800")]
    # the stamp is when the last byte arrived: first byte = stamp - length * byte time
    t_cmd = 0.321418 - 9 * BT
    assert chunks[0].t == 0.0
    assert chunks[1].t == pytest.approx((0.371708 - 1 * BT) - t_cmd, abs=1e-9)
    assert chunks[2].t == pytest.approx((0.374893 - 16 * BT) - t_cmd, abs=1e-9)


def test_real_nanoseconds_are_recognised(tmp_path):
    log = LOG.replace(".000321418", ".321418000").replace(".000371708", ".371708000") \
             .replace(".000374893", ".374893000")
    chunks = list(SocatLogSource(write(tmp_path, log), BT).chunks())
    assert chunks[1].t == pytest.approx(0.371708 - BT - (0.321418 - 9 * BT), abs=1e-9)


def test_hex_only_log_without_text_column(tmp_path):
    log = "\n".join(line[:49].rstrip() if line.startswith(" ") else line
                    for line in LOG.splitlines() if line != "--") + "\n"
    chunks = list(SocatLogSource(write(tmp_path, log), BT).chunks())
    assert chunks[0].data.hex() == "f80101010002503f94"
    assert len(chunks) == 3


def test_text_column_is_never_read_as_hex(tmp_path):
    # 'ab cd' in the text column looks like hex tokens but sits past column 49
    log = "> 2026/11/21 08:35:52.000321418  length=5 from=0 to=4\n" \
          " 61 62 20 63 64                                   ab cd\n--\n"
    (chunk,) = SocatLogSource(write(tmp_path, log), BT).chunks()
    assert chunk.data == b"ab cd"


def test_missing_bytes_and_short_chunks_are_warned(tmp_path):
    log = LOG.replace("from=1 to=16", "from=5 to=20").replace("length=9", "length=10")
    src = SocatLogSource(write(tmp_path, log), BT)
    warnings = []
    src.report_to(warnings.append)
    list(src.chunks())
    assert any("jumps from byte 1 to 5" in w for w in warnings)
    assert any("length=10 but carries 9 bytes" in w for w in warnings)


def test_detect_picks_socat_and_rejects_other_text(tmp_path):
    assert isinstance(detect([write(tmp_path, LOG)], BT), SocatLogSource)
    with pytest.raises(CaptureError, match="not a socat -x -v log"):
        detect([write(tmp_path, "hello\nworld\n", "notes.txt")], BT)


def test_socat_diagnostics_lines_are_skipped(tmp_path):
    log = "2026/11/21 08:35:51 socat[123] N PTY is /dev/pts/3\n" + LOG
    assert len(list(detect([write(tmp_path, log)], BT).chunks())) == 3
