"""Wire and file formats that readers (analyzer/sources) and writers
(analyzer/writers) share, so that neither imports the other:

- ``pcapng``: pcapng blocks, written and walked (docs/wireshark.md);
- ``pdu``: an event as a Wireshark exported-PDU packet, and back;
- ``mcap_schemas`` and ``mcap_messages``: the MCAP topics' JSON schemas and
  the messages a run makes for them (docs/mcap.md);
- ``parquet_schema`` and ``parquet_rows``: the fleet dataset's tables and the
  rows a capture gives them (docs/dataset.md);
- ``fit_width``: tables and lines of text that fit the terminal's width (the
  tables of ``stats``, ``report`` and the TUI's statistics screen).

Nothing here opens a file or a port: these modules turn values into bytes and
rows, and back.
"""
