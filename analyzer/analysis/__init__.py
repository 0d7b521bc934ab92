"""What the events mean, computed from the events alone (pure: no I/O, no
threads): request/response pairing and the transaction record, the alignment of
untimed lines, echo stripping, rate following, clock skew between two
adapters, statistics, gimbal positions, the display filter language and the
wiring doctor. Everything above (the capture, writers, listeners, the TUI, the
command line) reads these; they read only the dissectors."""
