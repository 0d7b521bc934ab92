"""Generated source files (the Wireshark dissector, the sigrok decoder, the
Saleae analyzer) are templates with ``@@NAME@@`` placeholders, filled from the
command table: one way of filling them, which refuses a placeholder left
unfilled rather than writing a file that fails inside the other tool."""

from __future__ import annotations

import re

_PLACEHOLDER = re.compile(r"@@\w+@@")


def fill(template: str, values: dict[str, str]) -> str:
    """``template`` with each ``@@KEY@@`` replaced by ``values[KEY]``."""
    text = template
    for key, value in values.items():
        text = text.replace("@@" + key + "@@", value)
    leftover = _PLACEHOLDER.search(text)
    if leftover:
        raise ValueError(f"template placeholder {leftover.group(0)} not filled")
    return text
