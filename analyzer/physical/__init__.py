"""The physical layer: lines sampled by a logic analyser, read as a UART reads
them (docs/instruments.md).

``edges`` turns samples into level changes (vectorised: a capture is hundreds
of millions of samples, its edges a few per bit); ``bitrate`` measures a line's
bit time, idle level and character format from its edges; ``uart`` decodes the
edges into bytes with their wire times, and tells the receiver's errors (framing,
parity, breaks) and the signs of a sick line (glitches, bits off the grid, a
sender's clock error) in a ``LineReport`` (``report``), which the wiring doctor
turns into findings.

Pure functions of the samples: no I/O, never raising on what the wire held.
"""
