"""Talking to gimbals (``probe``, ``send``; docs/talk.md): the one part of
gimbalscope that writes to a port, and only when a command says so. Taps never do."""
