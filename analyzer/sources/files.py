"""Opening input files with one clear error line for every way it can fail."""

from __future__ import annotations

import os
from typing import BinaryIO

from .base import CaptureError


def open_input(path: str) -> BinaryIO:
    try:
        if os.path.isdir(path):
            raise CaptureError(f"{path}: is a directory, not a capture file")
        return open(path, "rb")
    except FileNotFoundError:
        raise CaptureError(f"{path}: no such file") from None
    except PermissionError:
        raise CaptureError(f"{path}: permission denied") from None
    except OSError as e:
        raise CaptureError(f"{path}: cannot read: {e.strerror or e}") from None
