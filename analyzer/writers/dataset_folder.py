"""The dataset folder a ``ParquetDatasetWriter`` writes into: a local folder, or
one behind a remote URI (``hdfs://``, ``s3a://``) through pyarrow's filesystems.

The writer's rule is the same on both (docs/dataset.md, "Layout"): a capture's
new files are written under a name readers skip and take the place of its old
ones once the capture has been read to its end. Locally that is an atomic
rename over the old file. A remote store has no such rename (S3 copies, HDFS
refuses to rename over a file), so there the old file is deleted first: a
reader in between sees the capture missing for a moment, never half of it.
"""

from __future__ import annotations

import glob
import os
from collections.abc import Iterable
from typing import Any, Protocol

from .. import uris

UNIQUE_TEXT = frozenset({"payload"})   # text columns whose values are mostly distinct (no dictionary)


class DatasetFolder(Protocol):
    """A dataset folder, local or remote: paths in it, its files' writers (pyarrow's
    ``ParquetWriter``, of a ``pyarrow.Schema``), and the files' replacement."""

    root: str

    def file(self, *names: str) -> str: ...
    def writer(self, path: str, schema: Any) -> Any: ...
    def files_named(self, tables: Iterable[str], partition: str, name: str) -> list[str]: ...
    def remove(self, path: str) -> None: ...
    def replace(self, src: str, dst: str) -> None: ...
    def drop_if_empty(self, folder: str) -> None: ...


def writer_options(schema: Any) -> dict[str, Any]:
    """How a table's files are written: zstd, and a dictionary only for the text
    columns whose values repeat (names, kinds, devices, statuses, text fields). A
    payload's text, a frame's bytes, times and numbers are mostly distinct: a
    dictionary tried on them is dropped again, at a third of the write's time."""
    import pyarrow as pa
    return {"compression": "zstd",
            "use_dictionary": [f.name for f in schema if f.type == pa.string() and f.name not in UNIQUE_TEXT]}


def folder_of(root: str) -> DatasetFolder:
    """The folder at ``root``: a local path or ``file://`` URI, or a remote URI."""
    path = uris.local_path(root)
    return LocalFolder(path) if path is not None else RemoteFolder(root)


class LocalFolder:
    def __init__(self, root: str) -> None:
        self.root = root

    def file(self, *names: str) -> str:
        return os.path.join(self.root, *names)

    def writer(self, path: str, schema: Any) -> Any:
        """A Parquet writer of a new file. Its partition folder may be new and
        empty until the file is made, and another capture exported alongside
        (``export -j``) removes partition folders it leaves empty: make the
        folder again if it went in between."""
        import pyarrow.parquet as pq
        tries = 3
        while True:
            os.makedirs(os.path.dirname(path), exist_ok=True)
            try:
                return pq.ParquetWriter(path, schema, **writer_options(schema))
            except FileNotFoundError:
                tries -= 1
                if not tries:
                    raise

    def files_named(self, tables: Iterable[str], partition: str, name: str) -> list[str]:
        out = []
        for table in tables:
            out += glob.glob(os.path.join(glob.escape(self.root), table, f"{partition}=*", glob.escape(name)))
        return out

    def remove(self, path: str) -> None:
        try:
            os.remove(path)
        except FileNotFoundError:
            pass

    def replace(self, src: str, dst: str) -> None:
        os.replace(src, dst)

    def drop_if_empty(self, folder: str) -> None:
        try:
            os.rmdir(folder)
        except OSError:
            pass   # not empty: another capture's files are there


class RemoteFolder:
    """A dataset folder behind a remote URI; paths are the filesystem's own
    (``bucket/key``, ``/path`` on HDFS), the URI's scheme and host left off."""

    def __init__(self, uri: str) -> None:
        self.uri = uri
        self.fs, self.root = uris.arrow_filesystem(uri)
        self.root = self.root.rstrip("/")

    def file(self, *names: str) -> str:
        return "/".join([self.root, *names])

    def writer(self, path: str, schema: Any) -> Any:
        import pyarrow.parquet as pq
        self.fs.create_dir(path.rsplit("/", 1)[0], recursive=True)
        return pq.ParquetWriter(path, schema, filesystem=self.fs, **writer_options(schema))

    def files_named(self, tables: Iterable[str], partition: str, name: str) -> list[str]:
        from pyarrow import fs
        out = []
        for table in tables:
            top = f"{self.root}/{table}"
            found = self.fs.get_file_info(fs.FileSelector(top, allow_not_found=True, recursive=True))
            out += [f.path for f in found if f.type == fs.FileType.File and f.base_name == name
                    and f.path[len(top) + 1:].startswith(partition + "=")]
        return out

    def remove(self, path: str) -> None:
        try:
            self.fs.delete_file(path)
        except FileNotFoundError:
            pass

    def replace(self, src: str, dst: str) -> None:
        self.remove(dst)
        self.fs.move(src, dst)

    def drop_if_empty(self, folder: str) -> None:
        from pyarrow import fs
        try:
            if not self.fs.get_file_info(fs.FileSelector(folder, allow_not_found=True)):
                self.fs.delete_dir(folder)
        except OSError:
            pass   # object stores keep no empty folders: nothing to drop
