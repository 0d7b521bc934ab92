"""The package's version, in a module of its own that imports nothing: whatever
writes it into a file (a recording's metadata, a pcapng header, the Lua
dissector, ``--version``) can read it at any point of the package's loading."""

__version__ = "0.1.0"
