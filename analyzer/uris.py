"""Where a fleet job's files are: a local path, or a URI that Spark and pyarrow's
filesystems both read (``file://``, ``hdfs://``, ``s3a://``; docs/spark.md).

Spark names S3 through Hadoop's connector (``s3a://``, older ``s3n://``);
pyarrow's own S3 filesystem calls the same objects ``s3://``, so the scheme is
translated for pyarrow and the URI is otherwise passed on as given. A
``file://`` URI is a local path, handled as one (atomic renames, real paths).

Nothing here imports pyarrow until a remote URI is opened: a local export or a
test of the rules costs no import.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING
from urllib.parse import unquote, urlsplit

if TYPE_CHECKING:
    from pyarrow import fs

# a scheme of two letters or more: "C:\\..." is a Windows drive, not a URI
_URI = re.compile(r"^([A-Za-z][A-Za-z0-9+.-]+)://")
# Hadoop's S3 schemes, which pyarrow knows as s3
_ARROW_SCHEME = {"s3a": "s3", "s3n": "s3"}


def scheme(text: str) -> str | None:
    """The URI scheme of ``text`` in lower case (None: a plain path)."""
    m = _URI.match(text)
    return m.group(1).lower() if m else None


def is_remote(text: str) -> bool:
    """A URI that is not a local file (``hdfs://``, ``s3a://``, …; ``file://HOST/``
    is another machine's file)."""
    return local_path(text) is None


def local_path(text: str) -> str | None:
    """The local path ``text`` names: itself, or a ``file://`` URI's path; None
    for a remote URI."""
    s = scheme(text)
    if s is None:
        return text
    if s != "file":
        return None
    parts = urlsplit(text)
    if parts.netloc not in ("", "localhost"):
        return None   # file://host/path: another machine's file
    return unquote(parts.path)


def failure(e: BaseException) -> str:
    """What a filesystem error (pyarrow's, which can run over several lines) says, on one line."""
    return " ".join(str(e).split()) or type(e).__name__


def arrow_filesystem(uri: str) -> tuple[fs.FileSystem, str]:
    """(pyarrow filesystem, path in it) for a remote URI. Raises ``OSError`` or
    ``ValueError`` (pyarrow's, or ``ArrowInvalid``) when the filesystem cannot be
    made: an unknown scheme, no libhdfs, bad credentials."""
    from pyarrow import fs

    s = scheme(uri) or ""
    arrow_uri = _ARROW_SCHEME[s] + uri[len(s):] if s in _ARROW_SCHEME else uri
    try:
        return fs.FileSystem.from_uri(arrow_uri)
    except OSError as e:
        if s == "hdfs":   # pyarrow reaches HDFS through Hadoop's own client library, in a JVM
            raise OSError(f"{failure(e)} (pyarrow's HDFS needs JAVA_HOME, HADOOP_HOME and "
                          "CLASSPATH=$(hadoop classpath --glob) set)") from None
        raise


def join(base: str, *names: str) -> str:
    """``base`` and ``names`` joined with ``/`` (a URI) or the OS's separator."""
    if scheme(base) is None:
        import os
        return os.path.join(base, *names)
    return "/".join([base.rstrip("/"), *names])
