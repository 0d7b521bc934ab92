"""Hostile inputs: a corpus the tests generate (hand-made MCAP records, foreign
recordings, cut and flipped files, broken socat logs, deep filters, FIFOs, a full
filesystem), each checked to give one clear line and lose nothing."""
