"""Wrong input is said (docs/inputs.md, "When the input is wrong"): decode, stats,
convert and export print one warning line for each error the wiring signs show
(lines swapped, a line at the wrong rate, input that is not this protocol), on
standard error, silenced by -q, and still exit 0; export refuses two raw dumps that
are one capture's two lines, and a folder named like a file."""

from __future__ import annotations

import random

import pytest

from tests.conftest import BUS, CTL, DEV, SOCAT_LOG, run_cli

SWAPPED = "lines swapped: the tap's line A carries the device's answers"
NOT_PROTOCOL = "almost nothing decodes: not traffic of this protocol, or read at the wrong rate"
WRONG_BAUD = "line B: bytes arrive but almost nothing decodes (wrong baud rate?)"


def noise(size: int, seed: int = 7) -> bytes:
    """Random bytes with none of the protocol's start or answer bytes (F8, ACK 06,
    NAK 15, NIC 3F): nothing in them can decode."""
    rng = random.Random(seed)
    allowed = [b for b in range(256) if b not in (0xF8, 0x06, 0x15, 0x3F)]
    return bytes(rng.choice(allowed) for _ in range(size))


def warnings(stderr: str, text: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("gimbalscope: warning: ") and text in line]


def commands(tmp_path, *inputs: str) -> dict[str, list[str]]:
    return {
        "decode": ["decode", *inputs],
        "stats": ["stats", *inputs],
        "convert": ["convert", *inputs, "-o", str(tmp_path / "out.jsonl"), "--force"],
        "export": ["export", "+".join(inputs), "-o", str(tmp_path / "fleet")],
    }


@pytest.mark.parametrize("command", ["decode", "stats", "convert", "export"])
def test_swapped_lines_are_said_once_and_q_silences_it(tmp_path, command):
    args = commands(tmp_path, DEV, CTL)[command]      # the sample's two dumps, the wrong way round
    r = run_cli(*args)
    assert r.returncode == 0, r.stderr
    said = warnings(r.stderr, SWAPPED)
    assert len(said) == 1, r.stderr
    # the advice names this command and the inputs in the right order
    fix = {"decode": f"gimbalscope decode {CTL} {DEV}", "stats": f"gimbalscope stats {CTL} {DEV}",
           "convert": f"gimbalscope convert {CTL} {DEV} -o OUT", "export": f"gimbalscope export {CTL}+{DEV}"}
    assert fix[command] in said[0]
    quiet = run_cli(*args, "-q")
    assert quiet.returncode == 0 and not warnings(quiet.stderr, SWAPPED), quiet.stderr


@pytest.mark.parametrize("command", ["decode", "stats", "convert", "export"])
def test_a_capture_of_this_protocol_the_right_way_round_gets_no_such_warning(tmp_path, command):
    r = run_cli(*commands(tmp_path, CTL, DEV)[command])
    assert r.returncode == 0, r.stderr
    for text in (SWAPPED, NOT_PROTOCOL, "wrong baud rate", "starts like"):
        assert not warnings(r.stderr, text), r.stderr


def test_a_garbled_line_b_is_a_wrong_baud_rate(tmp_path):
    dev = tmp_path / "dev.bin"
    dev.write_bytes(noise(2000))
    r = run_cli("decode", CTL, dev)
    said = warnings(r.stderr, WRONG_BAUD)
    assert r.returncode == 0 and len(said) == 1, r.stderr
    assert "2,000 bytes, 0% in valid frames or answers" in said[0]
    assert "--baud RATE" in said[0]
    assert not warnings(r.stderr, NOT_PROTOCOL)


def test_input_of_no_known_format_that_does_not_decode_is_not_this_protocol(tmp_path):
    junk = tmp_path / "junk.bin"
    junk.write_bytes(noise(5000))
    for command in ("decode", "stats"):
        r = run_cli(command, junk)
        assert r.returncode == 0, r.stderr
        said = warnings(r.stderr, NOT_PROTOCOL)
        assert len(said) == 1 and "5,000 bytes, 0% in valid frames or answers" in said[0], r.stderr
        assert "check the input is a tap of the gimbals' serial lines" in said[0]


@pytest.mark.parametrize("head, what", [
    (b"\x7fELF\x02\x01\x01", "an ELF executable"),
    (b"PK\x03\x04\x14\x00", "a ZIP archive"),
    (b"\xd4\xc3\xb2\xa1\x02\x00\x04\x00", "a pcap capture (tcpdump)"),
])
def test_a_file_of_another_format_is_named_as_such(tmp_path, head, what):
    f = tmp_path / "mistake.bin"
    f.write_bytes(head + noise(3000))
    r = run_cli("decode", f)
    assert r.returncode == 0
    said = warnings(r.stderr, "starts like")
    assert said == [(f"gimbalscope: warning: {f}: starts like {what}, not a serial capture; "
                     "decoded as raw bytes all the same")]
    assert len(warnings(r.stderr, NOT_PROTOCOL)) == 1


def test_export_refuses_the_two_lines_of_one_capture_given_as_two(tmp_path):
    out = tmp_path / "fleet"
    for given in ((CTL, DEV), (DEV, CTL)):
        r = run_cli("export", *given, "-o", out)
        assert r.returncode == 2, r.stderr
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and "look like the two lines of one capture" in lines[0]
        assert f"export them as one input, {CTL}+{DEV}, or add --separate" in lines[0]
        assert not out.exists()
    r = run_cli("export", CTL, DEV, "-o", out, "--separate")
    assert r.returncode == 0 and "exported 2 of 2 captures" in r.stderr


def test_export_of_separate_captures_is_not_refused(tmp_path):
    # a single-line dump of the whole bus carries commands of its own: no device's side
    r = run_cli("export", BUS, CTL, SOCAT_LOG, "-o", tmp_path / "fleet")
    assert r.returncode == 0, r.stderr
    assert "exported 3 of 3 captures" in r.stderr


@pytest.mark.parametrize("name", ["out.txt", "fleet.parquet", "dataset.json"])
def test_export_refuses_a_new_folder_named_like_a_file(tmp_path, name):
    out = tmp_path / name
    r = run_cli("export", SOCAT_LOG, "-o", out)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and f"{out}: {out.suffix} is a file's suffix" in lines[0]
    assert not out.exists()


def test_export_to_a_csv_file_names_convert(tmp_path):
    # CSV is one capture's table: convert writes it
    out = tmp_path / "dataset.csv"
    r = run_cli("export", SOCAT_LOG, "-o", out)
    assert r.returncode == 2
    assert r.stderr.strip().splitlines() == [(f"gimbalscope: error: {out}: export writes a dataset folder or a "
                                             f".pcapng file; for one .csv file use: gimbalscope convert CAPTURE "
                                             f"-o {out}")]
    assert not out.exists()


def test_export_takes_an_existing_folder_whatever_its_name(tmp_path):
    out = tmp_path / "fleet.v2"
    out.mkdir()
    r = run_cli("export", SOCAT_LOG, "-o", out)
    assert r.returncode == 0, r.stderr
    assert any(out.rglob("*.parquet"))
