"""Every finding the wiring doctor (analyzer/analysis/doctor.py) can raise, in one
table, like the problems of dissectors/problems.py: an id (the ``code`` of the JSON
report, of the Parquet findings and of the TUI's findings), a severity, what the
traffic shows (the findings table of docs/doctor.md is rendered from it), the words
of the finding, and which other findings it explains.

The words are ``str.format`` templates with named fields. A rule says only what it
measured and which entry it is::

    FINDINGS[SILENT_DEVICE].found(addr, evidence, addr=addr, commands=12, answering="1.1.1")

Wording that depends on what was measured (an optional clause, one of two fixes) is
a *phrase* of the entry, filled the same way and passed as a field::

    noisy = FINDINGS[NOISY_LINK]
    noisy.found(..., trend=noisy.phrase("rising", per_min=12.0), ...)

A root cause explains its consequences: a finding ``hides`` the findings whose ids
it names (and, with ``hides_subject``, every finding about the same line or
device). ``WiringDoctor.findings`` runs its rules in order and drops what a kept
finding of an earlier rule hides.

    python -m analyzer.analysis.findings    # the findings table of docs/doctor.md
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from string import Formatter
from typing import Any

from ..styles import ERROR, INFO, WARNING  # the severities every view colours

# ------------------------------------------------------------------ ids
LINES_SWAPPED = "lines_swapped"
WRONG_BAUD = "wrong_baud"
NOT_THIS_PROTOCOL = "not_this_protocol"
NO_FRAMES = "no_frames"
DEAD_LINK = "dead_link"
SILENT_AFTER_RATE = "silent_after_rate"
ECHO = "echo"
SILENT_DEVICE = "silent_device"
NOISY_LINK = "noisy_link"
NAK_BURST = "nak_burst"
CONTROLLER_NO_WAIT = "controller_no_wait"
CONTROLLER_FAST_RETRY = "controller_fast_retry"
CONTROLLER_NO_RETRY = "controller_no_retry"
CONTROLLER_IX_TIMEOUT = "controller_ix_timeout"
SLOW_ANSWERS = "slow_answers"
DEVICE_MAP = "device_map"
# the waveform (a logic analyser's capture: analyzer/physical)
LINE_INVERTED = "line_inverted"
CLOCK_OFF = "clock_off"
RATE_NONSTANDARD = "rate_nonstandard"
FRAMING_ERRORS = "framing_errors"
GLITCHES = "glitches"
TWO_DRIVERS = "two_drivers"

# what the controller is seen doing: all of it follows from a link that is broken
CONTROLLER = (CONTROLLER_NO_WAIT, CONTROLLER_FAST_RETRY, CONTROLLER_NO_RETRY, CONTROLLER_IX_TIMEOUT)


@dataclass
class Finding:
    """What the doctor found, in words, with its evidence: made by a table entry's ``found``."""
    code: str                  # the id of its table entry: LINES_SWAPPED, ECHO, ...
    severity: str
    title: str                 # one line, plain words
    detail: str                # what the traffic shows
    fix: str                   # what to try
    evidence: list[int] = field(default_factory=list)   # event numbers
    subject: str = ""          # the line or device it is about
    first_seen: float | None = None   # capture time it was first found (None without time)
    first_seen_event: int | None = None   # events seen when it was first found
    # what the rule measured, for scripts and tests rather than the words: wrong_baud's
    # named rate {"baud": 9600, "read": 19200}, what bytes look like {"looks": "text"}
    measured: dict = field(default_factory=dict)

    @property
    def key(self) -> tuple[str, str]:
        return self.code, self.subject

    def to_dict(self) -> dict:
        return {"code": self.code, "severity": self.severity, "subject": self.subject, "title": self.title,
                "detail": self.detail, "fix": self.fix, "evidence": self.evidence, "first_seen": self.first_seen,
                "first_seen_event": self.first_seen_event, "measured": self.measured}


def fields_of(template: str) -> set[str]:
    """The named fields a template fills: ``"{n} bytes, {share:.0%}"`` -> {n, share}."""
    return {name for _text, name, _spec, _conv in Formatter().parse(template) if name}


@dataclass(frozen=True, eq=False)
class FindingKind:
    """One entry of the table. Compared by identity, like the problems' table."""
    id: str                    # the finding's code, LINES_SWAPPED
    severity: str              # ERROR, WARNING or INFO
    shows: str                 # what the traffic shows, for people (docs/doctor.md's table; Markdown)
    title: str                 # templates of the finding's words
    detail: str
    fix: str
    phrases: dict[str, str] = field(default_factory=dict)   # wording the rule picks from, by name
    hides: tuple[str, ...] = ()      # ids of the findings this one explains
    hides_subject: bool = False      # and every finding about its subject

    @property
    def fields(self) -> set[str]:
        """The fields a rule passes to ``found``."""
        return fields_of(self.title) | fields_of(self.detail) | fields_of(self.fix)

    def found(self, subject: str, evidence: list[int], **values: Any) -> Finding:
        """The finding, its templates filled with what the rule measured."""
        values = _worded(values)
        return Finding(self.id, self.severity, self.title.format(**values), self.detail.format(**values),
                       self.fix.format(**values), evidence, subject)

    def phrase(self, name: str, **values: Any) -> str:
        """One of the entry's phrases, filled."""
        return self.phrases[name].format(**_worded(values))


class _Count(int):
    """A count in a template: thousands separated (``151,344 bytes``) as every
    message words counts; a format spec in the template still applies."""

    def __format__(self, spec: str) -> str:
        return format(int(self), spec or ",")


PLAIN_NUMBERS = {"baud", "read", "before"}   # line rates are written as the spec writes them: 115200


def _worded(values: dict[str, Any]) -> dict[str, Any]:
    return {k: _Count(v) if type(v) is int and k not in PLAIN_NUMBERS else v for k, v in values.items()}


TABLE: list[FindingKind] = []


def _kind(*args: Any, **kw: Any) -> FindingKind:
    kind = FindingKind(*args, **kw)
    TABLE.append(kind)
    return kind


# A wire fault leaves every command unanswered and the controller in trouble.
_WIRE_CONSEQUENCES = (DEAD_LINK, SILENT_DEVICE, NAK_BURST, NOISY_LINK, *CONTROLLER)
_CHECK_WIRE_B = ("check the device→controller wire and the tap on it (RX/TX swapped, a loose pin, the adapter), "
                 "then the devices' power")

# ---------------------------------------------------------------- the wiring
_kind(LINES_SWAPPED, ERROR,
      "ACK/NAK/NIC bytes on line A and command frames on line B (`--swap-lines`, or `x` in a live TUI, "
      "fixes it without restarting)",
      "lines swapped: the tap's line A carries the device's answers",
      # the counts come worded ("12 ACK/NAK/NIC bytes", "1 command"): analyzer/words.py
      "{answer_bytes} arrived on line A and {command_frames} on line B; {answered} answered as wired",
      "{swap_fix}",           # where the traffic is read decides: Invocation.swap_fix
      hides=_WIRE_CONSEQUENCES)
_kind(WRONG_BAUD, ERROR,
      "bytes arrive on a line but under 30% of them decode, and they read like this protocol misread at another "
      "rate (or other lines decode, or the line is a port's); names the line's rate when one stands out "
      "(otherwise `--scan-baud`)",
      "line {line}: bytes arrive but almost nothing decodes (wrong baud rate?)",
      # noise_bytes: "1 byte"; bad_frames: "1 frame with a bad checksum" (analyzer/words.py)
      "{bytes} bytes, {share:.0%} in valid frames or answers, {noise_bytes} of noise, "
      "{bad_frames}{misread}{rhythm}",
      "{baud_fix}",           # Invocation.baud_fix, or Invocation.rate_fix when the rate is named
      phrases={"rate": "; they read like this protocol at {baud} bps misread by the tap at {read} bps",
               "rate_file": "; they read like this protocol at {baud} bps misread by a tap at {read} bps, the rate "
                            "this capture is read at (--baud, or a recording's own): the line runs at {ratio} "
                            "the tap's rate",
               "times": "{n} times",
               "part": "{n}/{d} of",
               "misread": "; they read like this protocol misread at another rate",
               "rhythm": "; line B answered line A's bursts {exchanges}, as devices answer commands"},   # "3 times"
      hides=(*_WIRE_CONSEQUENCES, NO_FRAMES))
_kind(NOT_THIS_PROTOCOL, ERROR,
      "a file's bytes, on every line, under 5% of them decoding, and nothing like this protocol misread at "
      "another rate (text, another protocol, random bytes, one byte over and over): not a tap of these "
      "gimbals' lines (on ports this is `wrong_baud`)",
      "almost nothing decodes: not traffic of this protocol, or read at the wrong rate",
      "{bytes} bytes, {share:.0%} in valid frames or answers; {looks}",
      "check the input is a tap of the gimbals' serial lines (a raw dump, socat log or recording); if it is, "
      "{baud_fix}",
      phrases={"text": 'printable ASCII text ("{excerpt}")',
               "same": "the byte {value} over and over",
               "binary": "not text, and not like this protocol misread at any standard rate"},
      hides=(WRONG_BAUD, LINES_SWAPPED, *_WIRE_CONSEQUENCES, NO_FRAMES))
_kind(NO_FRAMES, WARNING,
      "not one valid frame on any line, and no `wrong_baud` or `not_this_protocol` (they judge lines of 100 "
      "bytes or more) to explain it: what the capture holds instead (nothing, text, one byte over and over, "
      "other bytes)",
      "{seen}, no frame of this protocol",
      "{looks}",
      "{check}",
      phrases={"on_line": "{bytes} on line {line}",
               "nothing": "no byte on any line",
               "text": 'printable ASCII text: "{excerpt}"',
               "same": "the byte {value} over and over",
               "binary": "bytes that are no frame: {head}",
               "empty": "nothing was read",
               "check_file": "check the input is a tap of the gimbals' serial lines (a raw dump, socat log or "
                             "recording) made while they talked",
               "check_port": "check the tap is on the gimbals' lines (RX on the wire it listens to, ground) and "
                             "that the controller is talking; if bytes come but no frame, {baud_fix}"})
# ---------------------------------------------------------------- the waveform
# Only a logic analyser's capture shows these: the software UART measured them
# (analyzer/physical/report.py). Each is about one line.
_kind(LINE_INVERTED, WARNING,
      "a line that rests low: read at RS-232 polarity (no transceiver between it and a logic-level input), or "
      "an RS-485 pair's wires crossed; decoded inverted all the same",
      "line {line} is inverted: it rests low ({channel})",
      "its {characters} read with the levels inverted",     # characters: "402 characters"
      "a logic-level UART cannot read it: if the probe is on the RS-232 side of a transceiver that is how it "
      "should look; otherwise put a transceiver (MAX232) between them, or swap the RS-485 pair's A and B")
_kind(CLOCK_OFF, WARNING,
      "a line's measured bit rate 2 % or more from the nominal one (an error from 4 %: a receiver samples "
      "the last bits of a character at their edges)",
      "line {line} runs at {rate:,.0f} bit/s, {pct:.1f} % {way}",
      "nominal {baud} bit/s, measured over {characters}; UARTs tolerate about 2 % each, 4-5 % "
      "between two ends, and errors grow with the character's length",
      "the sender's clock is off: check its crystal or clock divisor (a rate its clock cannot make exactly), "
      "or set both ends to a rate it makes better",
      hides=(NOISY_LINK,), hides_subject=False)
_kind(RATE_NONSTANDARD, WARNING,
      "a line's measured bit rate more than 8 % from every standard rate: decoded at the rate measured",
      "line {line} runs at {rate:,.0f} bit/s, no standard rate",
      "measured over {characters}; the nearest standard rate is {nearest:,} bit/s",
      "a gimbal link runs at a rate of §1.5.1: check the sender's rate setting and clock divisor, or whether "
      "the probe is on this protocol's line at all")
_kind(FRAMING_ERRORS, ERROR,
      "characters whose stop bit is not at the idle level, breaks (a line held active), parity errors",
      # errors: "3 framing errors in 402 characters, and 2 breaks": a break has no
      # value, so it is no character, and is counted separately from them
      "line {line}: {errors}",
      "first at {first}",
      "{check}",
      phrases={"in": "{errors} in {characters}",
               "check_rate": "a wrong rate or format gives framing errors on most characters: check both ends' "
                             "settings ({format} read here)",
               "check_line": "a few framing errors are a disturbed line: check the cable, its shield and ground; "
                             "a break is a sender holding the line (a reset, a driver left on)"},
      hides=(NOISY_LINK,))
_kind(GLITCHES, WARNING,
      "pulses shorter than a quarter bit on a line (removed before decoding, as a receiver's filter would)",
      "line {line}: {glitches} (pulses under a quarter bit)",     # "3 glitches"
      "{pulses} under {limit_us:.1f} µs among {edges}",
      "interference or ringing: check the cable's shield and ground, its length and termination (RS-485: "
      "120 Ω at both ends)")
_kind(TWO_DRIVERS, ERROR,
      "characters whose edges fall off the bit grid: two senders driving one line at once (RS-485 bus "
      "contention, a driver left enabled)",
      "line {line}: two senders at once",
      "{off_grid} of {characters} have edges off the bit grid",     # characters: "402 characters"
      "on a shared (RS-485) line only one device may drive at a time: check that each releases the bus after "
      "sending (its driver-enable timing), and that no two devices answer to the same address",
      hides=(NOISY_LINK, FRAMING_ERRORS))
_kind(DEAD_LINK, ERROR,
      "commands, and no device answers at all (line B silent, or garbled)",
      "no device answers at all",
      "{commands} commands, no ACK or NAK; {where}",
      "{check}",
      phrases={"b_silent": "line B is silent: no byte came back",
               "none_answered": "no device answered",
               "b_garbled": "line B carries {bytes} but no answer to a command",      # bytes: "1 byte"
               "line_garbled": "the line carries {bytes} but no answer to a command",
               "check_wire": _CHECK_WIRE_B,
               "check_baud": "check the baud rate and the devices' addresses",
               # what send and probe say when they talk and nothing answers (docs/talk.md)
               "check_talking": "check the gimbal's power, the wiring (our TX to its RX, its TX to our RX, "
                                "ground), the rate (gimbalscope probe tries each) and the address (probe finds it)"},
      hides=CONTROLLER)
_kind(SILENT_AFTER_RATE, ERROR,
      "a device that answered stops answering once the link's rate was changed (it ACKed and did not "
      "switch, or cannot talk at the new rate)",
      "{silence}",
      "{commands} commands to {addr} since the rate change, no ACK or NAK; it answered {answered} at "
      "{before} bps before",      # answered: "1 time"
      "the device ACKed the change but does not talk at {baud} bps: ask it for its highest rate (B?) at {before} "
      "bps, set the controller back to {before} bps, or power-cycle the device (it starts at its default rate)",
      phrases={"set_to": "{addr} was set to {baud} bps at {at} and has not answered since",
               "link_set_to": "{addr} has not answered since the link was set to {baud} bps at {at}"},
      # the rate change explains the silence, and what the controller does about it
      hides=(SILENT_DEVICE, DEAD_LINK, *CONTROLLER), hides_subject=True)
_kind(ECHO, WARNING,
      "line B repeats line A's frames as they are sent; the copies are dropped from decoding (the raw bytes "
      "stay in recordings)",
      "line B repeats line A (echo): stripped from decoding",
      "{echoes} commands came back on line B byte for byte while they were being sent",
      "a half-duplex adapter or RS-485 converter echoes what it sends: disable its echo (or local loopback) if "
      "the controller is confused by it; decoding already ignores the copies")
_kind(SILENT_DEVICE, WARNING,
      "one address never answers while others do",
      "device {addr} never answers",
      "{commands} commands to {addr}, no ACK or NAK, while {answering} answer",
      "check {addr}'s power and address setting, and its drop on the bus")
_kind(NOISY_LINK, WARNING,
      "checksum errors and noise runs per line and per minute, the trend, and whether long frames fail more "
      "often than short ones (a clock or baud mismatch)",
      "line {line} is noisy",
      "{checksum_errors} and {noise_runs} {span}{trend}{length}",
      "{check}",
      phrases={"timed": "in {seconds:.0f} s ({per_min:.1f}/min)",
               "untimed": "in {events}",
               "rising": "; rising: {per_min:.0f}/min in the last minute",
               "falling": "; falling: {per_min:.0f}/min in the last minute",
               "length": "; long frames fail {long:.0%}, short ones {short:.0%}: errors grow with length, "
                         "like a clock (baud) mismatch or timing problem",
               "check_cable": "check the cable (shielding, length, grounding) and the connectors",
               "check_clock": "check both ends run the same baud rate (a slightly off clock), then the cable"})
_kind(NAK_BURST, WARNING,
      "five NAKs or more within 10 s, three times the usual rate",
      "NAK bursts: devices reject commands in runs",
      "{naks} NAKs, up to {burst} within 10 s",
      "devices NAK what they receive corrupted: check the controller→device wire (line A)")

# ---------------------------------------------------------------- the controller
_kind(CONTROLLER_NO_WAIT, WARNING,
      "the controller sends the next command before an ACK could come",
      "the controller sends before the previous ACK",
      "{commands} commands were followed by the next one after {gap_ms:.1f} ms (median), before any ACK/NAK; "
      "devices take up to {p95_ms:.0f} ms to answer",
      "the controller must wait for ACK/NAK (or its timeout) before the next command (§1.4.2)",
      # answers cannot be matched to commands sent on top of each other: their
      # latencies say nothing about the devices
      hides=(SLOW_ANSWERS,))
_kind(CONTROLLER_FAST_RETRY, WARNING,
      "the controller retries sooner than devices answer",
      "the controller retries sooner than devices answer",
      "{retries} retries came {gap_ms:.0f} ms (median) after the command, while devices' ACKs take up to "
      "{p95_ms:.0f} ms",
      "raise the controller's ACK timeout above the devices' answer time")
_kind(CONTROLLER_NO_RETRY, WARNING,
      "the controller never sends a NAK'd or unanswered command again",
      "the controller never retries a failed command",
      "{given_up} commands NAK'd or unanswered were not sent again{retried}",
      "retransmit after NAK or an ACK timeout (the spec's handshake expects it)",
      phrases={"retried": " ({retried} were)", "retried_one": " (1 was)"})
_kind(CONTROLLER_IX_TIMEOUT, WARNING,
      "the controller resends IX (initialise) before its result",
      "the controller gives up on IX before it ends",
      "{resent}; initialisation takes seconds (up to a minute)",
      "wait for IX's result (60 s is safe) before resending or moving on",
      phrases={"resent": "{resent} IX commands were sent again before their result came",
               "resent_one": "1 IX command was sent again before its result came"})

# ---------------------------------------------------------------- the devices
_kind(SLOW_ANSWERS, WARNING,
      "a device's ACK latency doubling (and 5 ms more) over the capture",
      "device {addr} answers slower and slower",
      "median ACK latency {before_ms:.1f} ms at first, {after_ms:.1f} ms lately ({acks} ACKs)",
      "a device slowing down is busy or failing: check {addr}'s load, power and temperature")
_kind(DEVICE_MAP, INFO,
      "every address, where it answers, which commands it NICs (what its firmware implements), its D? identity",
      "{devices} addressed{past}",           # devices: "3 devices"
      "{per_device}",         # a line per device, then the commands past counting
      "",
      phrases={"past": ", and more (past {limit})",
               "device": "{addr}: {commands}, {state}{nic}{identity}",   # commands: "1 command"
               "answers": "answers on {lines}",
               "never_answered": "never answered",
               "nic": "; NIC to {commands}",
               "identity": "; {identity}",
               "untracked": "{commands} to further addresses, not tracked one by one"})

FINDINGS: dict[str, FindingKind] = {kind.id: kind for kind in TABLE}


def unexplained(batches: Iterable[list[Finding]]) -> list[Finding]:
    """The findings of the doctor's rules, batch by batch in the rules' order, less
    those a kept finding of an earlier batch hides. A hidden finding hides nothing."""
    out: list[Finding] = []
    hidden: set[str] = set()             # ids hidden so far
    hidden_subjects: set[str] = set()    # lines or devices whose findings are hidden
    for batch in batches:
        kept = [f for f in batch if f.code not in hidden and f.subject not in hidden_subjects]
        for f in kept:
            kind = FINDINGS[f.code]
            hidden.update(kind.hides)
            if kind.hides_subject:
                hidden_subjects.add(f.subject)
        out.extend(kept)
    return out


def render() -> str:
    """The findings table of docs/doctor.md (section "Wiring doctor")."""
    lines = ["| finding | severity | what the traffic shows | explains (not raised with it) |",
             "|---|---|---|---|"]
    for kind in TABLE:
        explains = [f"`{code}`" for code in kind.hides]
        if kind.hides_subject:
            explains.append("any finding about the same device")
        lines.append(f"| `{kind.id}` | {kind.severity} | {kind.shows} | {', '.join(explains) or '—'} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(render(), end="")
