"""Files that are plainly something else, told by their first bytes: given where a
raw dump is expected (``decode /bin/ls``, a tcpdump ``.pcap``, a ``.zip``), they
would decode as thousands of noise events with no word why. A raw serial dump has
no signature, so any bytes may start one; these signatures are long enough (or
specific enough) that a real tap does not begin with them."""

from __future__ import annotations

SIGNATURES: tuple[tuple[bytes, str], ...] = (
    (b"\x7fELF", "an ELF executable"),
    (b"PK\x03\x04", "a ZIP archive"),
    (b"PK\x05\x06", "a ZIP archive"),
    (b"\xd4\xc3\xb2\xa1", "a pcap capture (tcpdump)"),
    (b"\xa1\xb2\xc3\xd4", "a pcap capture (tcpdump)"),
    (b"\x4d\x3c\xb2\xa1", "a pcap capture (tcpdump)"),
    (b"\xa1\xb2\x3c\x4d", "a pcap capture (tcpdump)"),
    (b"\x89PNG\r\n\x1a\n", "a PNG image"),
    (b"\xff\xd8\xff", "a JPEG image"),
    (b"%PDF-", "a PDF document"),
    (b"7z\xbc\xaf\x27\x1c", "a 7-Zip archive"),
    (b"SQLite format 3\x00", "an SQLite database"),
    (b"PAR1", "a Parquet file"),
)
TAR_AT, TAR = 257, b"ustar"


def foreign_format(head: bytes) -> str | None:
    """What ``head`` (a file's first bytes) says the file is, when it is a known
    format that is not a capture; None otherwise."""
    for magic, name in SIGNATURES:
        if head.startswith(magic):
            return name
    if head[TAR_AT:TAR_AT + len(TAR)] == TAR:
        return "a tar archive"
    return None
