"""How the logic analysers' formats are recognised from an input's head: the
checks the readers registry runs (registry.py declares these formats, with
openers that import their readers only when a file is one: the readers need
numpy, which detecting any other input, and starting every command, must not
load). The readers themselves: sigrok.py, vcd.py, saleae_csv.py (with
saleae_table.py), saleae_binary.py.
"""

from __future__ import annotations

import re
import struct

from ..errors import CaptureError
from .files import Input

LOCAL = b"PK\x03\x04"          # a zip's local file header: a sigrok session
CENTRAL = b"PK\x01\x02"        # an entry of a zip's central directory
# a VCD starts with one of its sections
STARTS = (b"$date", b"$version", b"$timescale", b"$comment", b"$scope", b"$var", b"$enddefinitions")
BOM = b"\xef\xbb\xbf"
_TIME_COLUMN = re.compile(rb"^\s*\"?Time ?\[s\]\"?\s*,", re.IGNORECASE)   # a Saleae digital CSV
COLUMNS = ("name", "type", "start_time", "duration", "data")      # a Saleae Async Serial data table
MAGIC = b"<SALEAE>"            # a Saleae binary export
_SAMPLES_MEMBER = re.compile(rb"logic-\d+(-\d+)?")
# the start of such a name, cut short
_CUT_NAME = re.compile(rb"v|ve|ver|vers|versi|versio|m|me|met|meta|metad|metada|l|lo|log|logi|logic|logic-\d*|"
                       rb"logic-\d+-\d*")
_FIRST_NAMES = (b"version", b"metadata")


def looks_like_session(head: bytes) -> bool:
    """A zip whose first member is sigrok's ``version``, ``metadata`` or a chunk of
    samples (``logic-1``, ``logic-1-1``: sessions saved in 2014 put them first);
    or the start of one, cut before that name ends (the file is all of the head
    then): the session reader says it is cut short."""
    if len(head) < 30:   # a file shorter than one local header: a zip's start, cut
        n = min(len(head), len(LOCAL))
        return n > 0 and head[:n] == LOCAL[:n]
    if not head.startswith(LOCAL):
        return False
    name_len = struct.unpack_from("<H", head, 26)[0]
    name = head[30:30 + name_len]
    if name in _FIRST_NAMES or _SAMPLES_MEMBER.fullmatch(name) is not None:
        return True
    return len(name) < name_len and (name == b"" or _CUT_NAME.fullmatch(name) is not None)


def looks_like_vcd(head: bytes) -> bool:
    """Text starting with a VCD section keyword, a ``$end`` closing it."""
    start = head.lstrip()
    return start.startswith(STARTS) and b"$end" in start[:4096]


def looks_like_digital_csv(head: bytes) -> bool:
    """``Time [s],…`` on the first line (Logic 1 wrote ``Time[s]``)."""
    head = head.removeprefix(BOM)
    return _TIME_COLUMN.match(head) is not None


def looks_like_table(head: bytes) -> bool:
    """A first line naming the Async Serial data table's columns."""
    first = head.split(b"\n", 1)[0].decode("utf-8-sig", "replace").lower()
    names = {c.strip().strip('"') for c in first.split(",")}
    return all(c in names for c in COLUMNS)


def looks_like_export(head: bytes) -> bool:
    return looks_like_digital_csv(head) or looks_like_table(head)


def vet_binary(inp: Input) -> None:
    """Given with others, every input is a channel's export."""
    if not inp.head.startswith(MAGIC):
        raise CaptureError(f"{inp.name}: not a Saleae binary export; several inputs must all be channels "
                           "exported together (digital_0.bin digital_1.bin)")
