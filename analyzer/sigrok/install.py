"""Putting the decoder where libsigrokdecode looks for it: ``<user data
dir>/libsigrokdecode/decoders/gimbal/`` (GLib's user data dir:
``$XDG_DATA_HOME``, else ``~/.local/share``), which libsigrokdecode's
``srd_init`` adds to its search path after the system's folders, so
sigrok-cli and PulseView find it without ``SIGROKDECODE_DIR``. Or into a folder
of the user's choosing (then ``SIGROKDECODE_DIR=<folder>``)."""

from __future__ import annotations

import os

from ..outfile import install_text, user_data_folder
from .decoder import DECODER_ID, init_source, pd_source


def user_decoders_folder() -> str:
    """libsigrokdecode's per-user decoders folder."""
    return os.path.join(user_data_folder(), "libsigrokdecode", "decoders")


def install(folder: str | None = None) -> list[str]:
    """Write ``<folder>/gimbal/__init__.py`` and ``pd.py``; the paths written. Raises OSError."""
    package = os.path.join(folder if folder is not None else user_decoders_folder(), DECODER_ID)
    os.makedirs(package, exist_ok=True)
    written = []
    for name, text in (("__init__.py", init_source()), ("pd.py", pd_source())):
        path = os.path.join(package, name)
        install_text(path, text)
        written.append(path)
    return written
