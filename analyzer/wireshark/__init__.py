"""Wireshark jobs (docs/wireshark.md): the Lua dissector generated from the
command table (``lua``), its installation (``install``) and the extcap live
capture (``extcap``). The pcapng format they share with the ``.pcapng`` writer
and reader is in analyzer/formats (``pcapng``, ``pdu``)."""
