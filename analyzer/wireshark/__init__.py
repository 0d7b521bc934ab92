"""Wireshark interop (docs/wireshark.md): events as pcapng packets
(``pdu``, ``pcapng``; the registry's ``.pcapng`` writer is
analyzer/writers/pcapng.py), the Lua dissector generated from the command table
(``lua``), its installation (``install``) and the extcap live capture
(``extcap``)."""
