"""Recording captures to MCAP (raw bytes, events, transactions, anomalies)."""

from .recorder import McapRecorder, RecordingError, RotatingRecorder

__all__ = ["McapRecorder", "RecordingError", "RotatingRecorder"]
