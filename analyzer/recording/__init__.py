"""Recording captures to MCAP (raw bytes, events, transactions, anomalies)."""

from .recorder import McapRecorder, RecordingError

__all__ = ["McapRecorder", "RecordingError"]
