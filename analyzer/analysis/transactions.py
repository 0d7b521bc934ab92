"""One row per transaction (a command and its answers), the same for every
consumer: the MCAP and Foxglove ``/transactions`` topic, the dataset's
``transactions`` table and ``Capture.transactions()``.

A command opens a transaction; the next command, or the end of the input,
closes it, from the command's pairing record (``analyzer.analysis.pairing.Transaction``,
like Wireshark's ``mdb_transaction_t``). Its answers are those the stream brought
before that next command: an answer can come much later (an optional result),
and a live tap and a re-decode of its recording must give the same row,
whatever their batches.
"""

from __future__ import annotations

from typing import Any

from dissectors.event import COMMAND, Event

from .pairing import Transaction


def without_nulls(fields: dict[str, Any]) -> dict[str, Any]:
    """``fields`` without the names that have no value (a reserved rate code's
    ``baud``): the schemas type each name, and null is no type of it."""
    if None in fields.values():
        return {k: v for k, v in fields.items() if v is not None}
    return fields


class OpenTransaction:
    """A command seen, and those of its answers seen since. ``ts`` is whatever
    time its consumer gives it (the recorder: the message's log time)."""

    __slots__ = ("answers", "command", "record", "ts")

    def __init__(self, ts: Any, command: Event) -> None:
        self.ts = ts
        self.command = command
        self.record = command.transaction
        self.answers: list[Event] = []

    def to_dict(self) -> dict[str, Any]:
        """The record's facts, as far as the answers seen so far go; fields and
        problems are the command's, then its answers' (a key without a value is
        left out: the /transactions schema, analyzer/formats/mcap_schemas.py)."""
        cmd, record, answers = self.command, self._paired(), self.answers
        numbers = [a.number for a in answers]
        fields = dict(without_nulls(cmd.fields))
        problems = list(cmd.problems)
        for answer in answers:
            if answer.number == record.result:
                fields.update(without_nulls(answer.fields))
            problems.extend(answer.problems)
        msg: dict[str, Any] = {"txn": record.number, "number": cmd.number}
        if record.command is not None:
            msg["command"] = record.command
        msg["device"] = record.device
        if record.status is not None:
            msg["status"] = record.status
        msg["retransmission"] = record.retransmission
        if record.ack in numbers and record.ack_latency is not None:
            msg["ack_latency"] = record.ack_latency
        if record.result in numbers and record.result_latency is not None:
            msg["result_latency"] = record.result_latency
        msg.update(answers=numbers, fields=fields, problems=problems)
        return msg

    def answer_numbers(self) -> tuple[int | None, int | None, int | None]:
        """The ACK (or NAK), NIC and result event numbers among the answers seen."""
        record = self._paired()
        seen = {a.number for a in self.answers}
        ack, nic, result = (n if n in seen else None for n in (record.ack, record.nic, record.result))
        return ack, nic, result

    def _paired(self) -> Transaction:
        """The command's record: rows are made of paired events, and pairing gives
        every command a ``Transaction``."""
        record = self.record
        assert isinstance(record, Transaction)
        return record


class TransactionRows:
    """Feeds on events in wire order; ``add`` gives back the transaction a
    command closed (None otherwise), ``finish`` the one still open."""

    __slots__ = ("_open",)

    def __init__(self) -> None:
        self._open: OpenTransaction | None = None

    def add(self, ev: Event, ts: Any = None) -> OpenTransaction | None:
        if ev.kind == COMMAND:
            done, self._open = self._open, OpenTransaction(ts, ev)
            return done
        txn = self._open
        if txn is not None and ev.transaction is not None and ev.transaction is txn.record:
            txn.answers.append(ev)
        return None

    def finish(self) -> OpenTransaction | None:
        done, self._open = self._open, None
        return done
