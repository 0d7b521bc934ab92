"""A sigrok session cut short, wherever the cut falls: real sessions from the
sigrok project's dumps, cut at every 64th byte and decoded by the console
command in this process (analyzer.cli.main.main).

Every cut says so in one line that names the file and where it was cut, never
a traceback. A cut that leaves nothing to read (in a member's header, in the
metadata, before the samples show a character) is that line alone, an error
(exit 2). A cut in the samples is read up to the cut, as a laptop that died
while saving leaves them (docs/instruments.md, "sigrok and PulseView"): the
bytes read are the whole session's first bytes, and the line is a warning
(exit 0), as a VCD or a compressed file cut short is read. A whole session that
is wrong keeps its own message: it is not cut.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import zipfile

import pytest

from analyzer.cli.main import main
from tests.conftest import ROOT

DUMPS = os.path.join(ROOT, "tests", "data", "sigrok-dumps")
STEP = 64
LINE = re.compile(r"^gimbalscope: (error|warning): .+$")


def decode(path: str) -> tuple[int, str, list[str]]:
    raw, err = io.BytesIO(), io.StringIO()
    out = io.TextIOWrapper(raw, encoding="utf-8", write_through=True)   # the writers write its buffer
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["decode", path, "--format", "jsonl"])
    out.flush()
    return code, raw.getvalue().decode(), err.getvalue().splitlines()


def bytes_by_line(jsonl: str) -> dict[str, bytes]:
    out: dict[str, bytearray] = {}
    for row in jsonl.splitlines():
        ev = json.loads(row)
        out.setdefault(ev["line"], bytearray()).extend(bytes.fromhex(ev["raw"]))
    return {line: bytes(b) for line, b in out.items()}


def samples_start(data: bytes) -> int:
    """Where the first chunk of samples' data starts: a cut before it leaves none."""
    z = zipfile.ZipFile(io.BytesIO(data))
    first = min((i for i in z.infolist() if i.filename.startswith("logic-")), key=lambda i: i.header_offset)
    name_len, extra_len = int.from_bytes(data[first.header_offset + 26:first.header_offset + 28], "little"), \
        int.from_bytes(data[first.header_offset + 28:first.header_offset + 30], "little")
    return first.header_offset + 30 + name_len + extra_len


@pytest.mark.parametrize("name", ["hello_world_8n1_9600.sr",              # version 2, one channel
                                  "max3232e_hello_world_57600_8n1.sr",    # two channels, one inverted
                                  "es51978.sr"])                          # version 1: metadata after samples
def test_a_session_cut_anywhere_says_it_is_cut_short(tmp_path, name):
    with open(os.path.join(DUMPS, name), "rb") as f:
        data = f.read()
    code, whole_out, whole_err = decode(os.path.join(DUMPS, name))
    assert code == 0, whole_err
    whole = bytes_by_line(whole_out)
    start = samples_start(data)
    meta_at = max(i.header_offset for i in zipfile.ZipFile(io.BytesIO(data)).infolist()
                   if i.filename == "metadata")
    path = str(tmp_path / "cut.sr")
    said = {0: 0, 2: 0}
    for n in range(STEP, len(data), STEP):
        with open(path, "wb") as f:
            f.write(data[:n])
        code, out, err = decode(path)
        where = f"cut at {n} of {len(data)}: {err}"
        assert all(LINE.match(line) for line in err), where
        cut = [line for line in err if f"{path}: " in line and "cut short" in line]
        assert len(cut) == 1, where
        said[code] = said.get(code, 0) + 1
        if code == 2:
            assert err == [f"gimbalscope: error: {path}: cut short at byte {n:,}, " + cut[0].split(", ", 1)[1]], where
            assert out == ""
        else:
            assert code == 0, where
            assert cut[0].startswith(f"gimbalscope: warning: {path}: "), where
            got = bytes_by_line(out)
            assert got and all(whole[line].startswith(b) for line, b in got.items()), where
        if n < start or n <= meta_at:
            assert code == 2, where        # nothing of the samples, or no metadata to read them by
    assert said[2] and (said[0] or start > len(data) - STEP)


def test_the_first_bytes_of_a_session(tmp_path):
    """Cut inside its first member's header, or its name: still a session cut short
    (not "not a sigrok session"), for a name that says .sr and for one that does not."""
    with open(os.path.join(DUMPS, "hello_world_8n1_9600.sr"), "rb") as f:
        data = f.read()
    for n in (1, 2, 4, 29, 30, 33, 37):
        for name in ("cut.sr", "cut.bin"):
            path = str(tmp_path / name)
            with open(path, "wb") as f:
                f.write(data[:n])
            code, out, err = decode(path)
            assert (code, out) == (2, "")
            assert err == [(f"gimbalscope: error: {path}: cut short at byte {n}, before sigrok's metadata: "
                            "nothing to read")], (n, name)


def whole(tmp_path, members: dict[str, bytes], name: str = "wrong.sr") -> str:
    path = str(tmp_path / name)
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for member, content in members.items():
            z.writestr(member, content)
    return path


def test_a_whole_session_that_is_wrong_keeps_its_message(tmp_path):
    real = zipfile.ZipFile(os.path.join(DUMPS, "hello_world_8n1_9600.sr"))
    meta = real.read("metadata").decode()
    samples = real.read("logic-1-1")
    cases = [
        ({"version": b"2", "metadata": meta.replace("capturefile=logic-1", "").encode(), "logic-1-1": samples},
         "the sigrok metadata names no capture file ([device 1] capturefile=)"),
        ({"version": b"2", "logic-1-1": samples}, "a zip without sigrok's metadata: not a sigrok session"),
        ({"version": b"2", "metadata": meta.replace("samplerate=625 kHz", "samplerate=fast").encode(),
          "logic-1-1": samples},
         "the sigrok metadata's sample rate 'fast' is not a rate (e.g. 1 MHz)"),
    ]
    for members, message in cases:
        path = whole(tmp_path, members)
        code, out, err = decode(path)
        assert (code, out, err) == (2, "", [f"gimbalscope: error: {path}: {message}"])
    # samples that show no traffic, in a whole session: the probes, not a cut
    path = whole(tmp_path, {"version": b"2", "metadata": meta.encode(), "logic-1-1": b"\xff" * len(samples)})
    code, _, err = decode(path)
    assert code == 2 and len(err) == 1 and "cut short" not in err[0] and "no channel toggles" in err[0]


def test_a_file_named_sr_that_is_no_zip(tmp_path):
    path = str(tmp_path / "text.sr")
    with open(path, "w") as f:
        f.write("hello, not a session\n")
    code, out, err = decode(path)
    assert (code, out) == (2, "")
    assert err == [(f"gimbalscope: error: {path}: not a sigrok session (a .sr file is a zip whose first member is "
                    "sigrok's version, its metadata or a chunk of samples, logic-1…)")]
