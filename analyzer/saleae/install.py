"""Writing the Saleae extension folder: ``<folder>/Gimbal/`` with
``extension.json``, the analyzer's module and its README. Logic 2 has no folder
it searches: the user loads ``extension.json`` once (Extensions panel → ⋮ →
Load Existing Extension) and Logic 2 reads the folder where it is, so
installing again updates it in place. By default the folder is under the
user's data dir (``$XDG_DATA_HOME``, else ``~/.local/share``)."""

from __future__ import annotations

import os

from ..outfile import install_text, user_data_folder
from .extension import NAME, files


def default_folder() -> str:
    """Where the extension folder goes unless told: ``<user data dir>/gimbalscope/saleae``."""
    return os.path.join(user_data_folder(), "gimbalscope", "saleae")


def install(folder: str | None = None) -> list[str]:
    """Write ``<folder>/Gimbal/``'s files; the paths written, extension.json's
    first. Raises OSError."""
    extension = os.path.join(folder if folder is not None else default_folder(), NAME)
    os.makedirs(extension, exist_ok=True)
    written = []
    for name, text in files().items():
        path = os.path.join(extension, name)
        install_text(path, text)
        written.append(path)
    return written
