"""Putting the dissector and the extcap launcher where Wireshark looks for
them (docs/wireshark.md, "Install"): its personal Lua plugin folder and its
personal extcap folder, as ``tshark -G folders`` names them; or one folder of
the user's choosing.

Both are plain files, so installing needs no Wireshark: without tshark to ask,
the folders are the ones Wireshark 4.x uses on this system's conventions (the
extcap folder moved in 4.2, so the launcher goes into both).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from dataclasses import dataclass

from ..outfile import install_text
from .lua import generate

LUA_NAME = "gimbal.lua"
EXTCAP_NAME = "gimbalscope-extcap"


@dataclass
class Folders:
    plugins: list[str]
    extcap: list[str]
    how: str            # where the names came from, for the user


def _tshark_folders() -> dict[str, str] | None:
    exe = shutil.which("tshark")
    if exe is None:
        return None
    try:
        out = subprocess.run([exe, "-G", "folders"], capture_output=True, text=True, timeout=30, check=False).stdout
    except (OSError, subprocess.SubprocessError):
        return None
    folders = {}
    for line in out.splitlines():
        key, sep, value = line.partition(":")
        if sep:
            folders[key.strip()] = value.strip()
    return folders or None


def personal_folders() -> Folders:
    """Wireshark's personal plugin and extcap folders for this user."""
    named = _tshark_folders()
    home = os.path.expanduser("~")
    config = os.path.join(os.environ.get("XDG_CONFIG_HOME") or os.path.join(home, ".config"), "wireshark")
    lib = os.path.join(home, ".local", "lib", "wireshark")
    if named:
        plugins = named.get("Personal Lua Plugins") or os.path.join(lib, "plugins")
        extcap = named.get("Personal Extcap path") or os.path.join(
            named.get("Personal configuration") or config, "extcap")   # 4.0 reads <config>/extcap
        return Folders([plugins], [extcap], "as tshark -G folders names them")
    return Folders([os.path.join(lib, "plugins")], [os.path.join(config, "extcap"), os.path.join(lib, "extcap")],
                   "tshark not found: Wireshark 4.x's personal folders")


def launcher() -> str:
    """The extcap program: this Python running ``analyzer.wireshark.extcap``."""
    return (f"#!{sys.executable}\n"
            "# gimbalscope's Wireshark extcap interface, written by 'gimbalscope wireshark install'.\n"
            "import sys\n"
            "from analyzer.wireshark.extcap import main\n"
            "sys.exit(main())\n")


def _write(path: str, text: str, mode: int) -> None:
    os.makedirs(os.path.dirname(path), exist_ok=True)
    install_text(path, text, mode)


def install(folder: str | None = None) -> list[str]:
    """Write the dissector and the launcher; the paths written. Raises OSError."""
    if folder is not None:
        folders = Folders([folder], [folder], "")
    else:
        folders = personal_folders()
    written = []
    lua = generate()
    for d in folders.plugins:
        path = os.path.join(d, LUA_NAME)
        _write(path, lua, 0o644)
        written.append(path)
    script = launcher()
    for d in folders.extcap:
        path = os.path.join(d, EXTCAP_NAME)
        _write(path, script, 0o755)
        written.append(path)
    return written
