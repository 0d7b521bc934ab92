"""The portable frame decoder: the text the sigrok decoder's ``pd.py`` and the
Saleae High Level Analyzer both embed (``@@FRAME_DECODER@@`` in their
templates), with ``@@NAME@@`` placeholders that ``source()`` fills from the
command and problem tables (``table``).

It runs inside another tool's embedded Python (libsigrokdecode's; Logic 2's
3.8), which cannot import gimbalscope: standard library only, Python 3.8
syntax, and no annotations evaluated (the file that embeds it starts with
``from __future__ import annotations``, which the table's derive functions
need). The deframing follows ``dissectors.deframer`` decision for decision
(docs/decoding.md, "Deframing"), with one simplification that a timed tap
allows: a silence longer than the frame gap ends a burst, no frame spans one,
so each burst is deframed on its own and its end is what the deframer calls
"final". The dissection follows ``dissectors.dissect``, and ``Conversation``
pairs answers with commands as ``analysis.pairing`` does (by its timeouts when
the host gives times: the Saleae analyzer does, the sigrok decoder does not);
the derive and summary functions are the table's own, copied in.

A problem is ``(severity, "category: detail", id)``: the severity and text
gimbalscope's events carry, and the id of ``dissectors.problems``.
"""

from __future__ import annotations

from ..templates import fill
from .table import table_values

TEMPLATE = r'''# ---------------------------------------------------------------- the frame decoder
# gimbalscope's deframing, dissection and pairing, without gimbalscope.
import re

START, ACK, NAK, NIC = 0xF8, 0x06, 0x15, 0x3F
SIMPLE = {ACK: 'ack', NAK: 'nak', NIC: 'nic'}
WILDCARD = 0xFF
MAX_FRAME = 256 + 7
NOISE_PIECE = 4096

# problem id -> (category text, severity); a problem is (severity, "category: detail", id)
PROBLEMS = @@PROBLEMS@@


class Category:
    def __init__(self, name):
        self.name = name
        self.text, self.severity = PROBLEMS[name]

    def problem(self, detail=''):
        return (self.severity, self.text + ': ' + detail if detail else self.text, self.name)


CHECKSUM, LENGTH, TRUNCATED, NOISE = (Category(n) for n in ('CHECKSUM', 'LENGTH', 'TRUNCATED', 'NOISE'))
MALFORMED, OUT_OF_RANGE, RESERVED = (Category(n) for n in ('MALFORMED', 'OUT_OF_RANGE', 'RESERVED'))
LOWERCASE_HEX, UNKNOWN_COMMAND, ORPHAN = (Category(n) for n in ('LOWERCASE_HEX', 'UNKNOWN_COMMAND', 'ORPHAN'))

BAUD_CODES = @@BAUD_CODES@@
ERROR_BITS = @@ERROR_BITS@@
STATUS_BITS = @@STATUS_BITS@@

# The command table (Tables 4-18): per command its parameter layout and its
# result layouts; a layout is its regular expression with a group per field.
COMMANDS = @@COMMANDS@@

# field name -> unit, for the fields that have one
UNITS = @@UNITS@@

# the table's derive functions and summary filling, as gimbalscope has them
@@FUNCTIONS@@

DERIVES = {@@DERIVE_NAMES@@}

for _c in COMMANDS:
    for _l in (_c['layout'],) + tuple(_c['results']):
        _l['rx'] = re.compile(_l['regex'], re.DOTALL)
        _l['lead_rx'] = re.compile(_l['lead'], re.DOTALL) if _l['lead'] is not None else None
BY_FIRST = {}
for _c in COMMANDS:
    BY_FIRST.setdefault(_c['layout']['prefix'][0], []).append(_c)
UNKNOWN_CODE = re.compile(rb'\*[A-Za-z]{1,3}|[\s\S]{1,2}')


# ---------------------------------------------------------------- dissection
def payload_text(payload):
    """Printable ASCII kept, the backslash doubled, anything else as \\xNN (dissectors.wire.payload_text)."""
    return ''.join('\\\\' if b == 0x5C else chr(b) if 0x20 <= b < 0x7F else '\\x%02x' % b for b in payload)


def decode_field(f, raw):
    codec = f['codec']
    if codec == 'hex':
        v = int(raw, 16)
        if f['signed'] and v & 0x8000:
            v -= 0x10000
        return v / f['divisor'] if f['divisor'] else v
    if codec == 'decimal':
        return int(raw)
    if codec == 'choice':
        return f['choices'].get(raw)
    text = raw.decode('latin-1')
    return text.strip() if f['strip'] else text


def check_field(f, value):
    if f['codec'] == 'choice' and value is None:
        allowed = ', '.join('%s (%s)' % (k.decode('latin-1'), v) for k, v in f['choices'].items())
        return OUT_OF_RANGE.problem('%s is none of %s' % (f['name'], allowed))
    if f['valid'] is not None and isinstance(value, (int, float)):
        lo, hi = f['valid']
        if not lo <= value <= hi:
            return OUT_OF_RANGE.problem('%s %s outside %s..%s' % (f['name'], value, lo, hi))
    return None


def match(layout, payload):
    """(values, problems, spans) when ``payload`` fits ``layout``, else None;
    spans: (field, first, end) character offsets in the payload."""
    m = layout['rx'].fullmatch(payload)
    if m is None:
        return None
    values, problems, spans, lower = {}, [], [], False
    for k, f in enumerate(layout['fields'], 1):
        raw = m.group(k)
        values[f['name']] = value = decode_field(f, raw)
        spans.append((f['name'], m.start(k), m.end(k)))
        problem = check_field(f, value)
        if problem:
            problems.append(problem)
        lower = lower or (f['hex'] and raw != raw.upper())
    if lower:
        problems.append(LOWERCASE_HEX.problem('numbers must be upper-case ASCII hex (\u00a71.4.1.2)'))
    if layout['derive'] is not None:
        extra = DERIVES[layout['derive']](values)
        if extra:
            problems.extend(extra)
    return values, problems, spans


def lead_ok(layout, rest):
    rx = layout['lead_rx']
    return rx is not None and bool(rest) and rx.match(rest[:1]) is not None


def closer(a, b, n):
    wa, wb = a['width'], b['width']
    return (abs(wa - n) if wa is not None else 1000) < (abs(wb - n) if wb is not None else 1000)


def dissect_command(payload):
    """(entry or None, command code, values, problems, spans), as dissectors.dissect."""
    candidates = BY_FIRST.get(payload[0], ()) if payload else ()
    for c in candidates:
        m = match(c['layout'], payload)
        if m is not None:
            values, problems, spans = m
            if c['reserved']:
                problems.insert(0, RESERVED.problem('%s is marked reserved (%s)' % (c['id'], c['ref'])))
            cid = c['id'].format(**values) if '{' in c['id'] else c['id']
            return c, cid, values, problems, spans
    best = None
    for c in candidates:
        lit = c['layout']['prefix']
        if not payload.startswith(lit):
            continue
        if len(lit) < 2 and not lead_ok(c['layout'], payload[len(lit):]):
            continue
        blit = best['layout']['prefix'] if best is not None else b''
        if best is None or len(lit) > len(blit) or (
                len(lit) == len(blit) and closer(c['layout'], best['layout'], len(payload))):
            best = c
    if best is not None:
        cid = best['id'] if '{' not in best['id'] else best['id'].replace('{aux_port}', payload[2:3].decode('latin-1'))
        why = MALFORMED.problem('expected %s (%s)' % (best['layout']['describe'], best['ref']))
        return best, cid, {}, [why], []
    m = UNKNOWN_CODE.match(payload)
    code = payload_text(m.group(0)) if m else ''
    return None, code, {}, [UNKNOWN_COMMAND.problem("'%s' is not in protocol rev 1.9" % code)], []


def dissect_result(entry, payload):
    """(values, problems, spans) of a result answering ``entry`` (None: an unknown command's)."""
    if entry is None:
        return {}, [], []
    for layout in entry['results']:
        m = match(layout, payload)
        if m is not None:
            return m
    if not entry['results'] or entry['due'] == 'none':
        return {}, [MALFORMED.problem('%s has no result (%s)' % (entry['id'], entry['ref']))], []
    expected = ' or '.join(l['describe'] for l in entry['results'])
    return {}, [MALFORMED.problem('expected %s (%s)' % (expected, entry['ref']))], []


def result_fits(entry, payload):
    """Does ``payload`` read as a result of ``entry``, giving values?"""
    return entry is not None and bool(entry['results']) and bool(dissect_result(entry, payload)[0])


def address_fits(cmd, dst, src):
    """Does a result to ``dst`` from group ``src`` come back from the command's
    destination? Groups swapped, port and device kept (Table 3)."""
    cg, cp, cd = cmd['dst']
    rg, rp, rd = dst
    if rg != cmd['src'] or (src != cg and cg != WILDCARD) or (rp != cp and cp != WILDCARD):
        return False
    return rd == cd or cd == WILDCARD or rd == 0


def address(a):
    return '%d.%d.%d' % tuple(a)


def command_summary(entry, values, problems, payload):
    """A command's text after its code, as gimbalscope's output.summary words it."""
    if entry is not None and values:
        return summarize(entry['summary'], values)
    if entry is not None and not (problems and problems[0][1].startswith(MALFORMED.text)):
        return entry['name'].lower()
    return "'%s'" % payload_text(payload)


def result_summary(entry, values, payload):
    if entry is not None and values:
        return summarize(entry['result_summary'], values)
    return "'%s'" % payload_text(payload)


def noise_summary(raw):
    """A noise event's text, as gimbalscope's output.summary words it."""
    shown = ' '.join('%02x' % b for b in raw[:12]) + (' \u2026' if len(raw) > 12 else '')
    return '{:,} byte{}: {}'.format(len(raw), '' if len(raw) == 1 else 's', shown)


def show_value(value, unit):
    if isinstance(value, list):
        value = ', '.join(map(str, value)) if value else 'none'
    return '%s %s' % (value, unit) if unit else str(value)


# ---------------------------------------------------------------- pairing
# gimbalscope's default timeouts (analysis.pairing.Timeouts): seconds, and the
# later commands after which an untimed tap gives a due result up
ACK_TIMEOUT, RESULT_TIMEOUT, UNTIMED_WINDOW = @@TIMEOUTS@@
MAX_AWAITING = 64   # commands awaiting results kept, at most (a runaway controller)


class Conversation:
    """Which command each answer of one tap belongs to, decided as gimbalscope's
    pairing decides it (analysis.pairing.Pairer): an ACK or NAK answers the
    latest command not yet ACKed or NAKed, or one whose ACK timeout passed; a
    NIC the command ACKed by the event just before it; a result the latest
    command awaiting one (the one awaiting its ACK first) whose address and
    result layout fit it, else the latest whose address fits and whose result
    is due. On a single-line tap it also tells commands from results.

    Times are seconds on any one clock, or None: with them, the ACK and result
    timeouts expire what waits, as gimbalscope's timed pairing does; without
    them, a due result is given up after UNTIMED_WINDOW later commands.
    Of the exchange's problems only orphans are said (an answer no command
    awaits, worded as gimbalscope words them); unanswered commands, missing
    results, retransmissions and late answers are gimbalscope's to find.

    ``sees_commands``: False for a tap of line B alone, where an answer no
    command awaits is no orphan: its command went by on the other line."""

    def __init__(self, sees_commands=True):
        self.sees_commands = sees_commands
        self.awaiting_ack = None   # the latest command not yet ACKed or NAKed
        self.timed_out = None      # one whose ACK timeout passed: a late ACK is still its
        self.last_ack = None       # the command the event just before this one ACKed
        self.awaiting_result = []  # ACKed commands a result is due from, oldest ACK first
        self.controller_groups = set()

    def answering(self, kind, t=None, t_end=None):
        """(the command an ACK, NAK or NIC answers, the problems of that): the
        command a dict with its 'command' code, 'dst', 'src' and 'entry', or
        None, an orphan."""
        cmd = self.answered_by(kind, t, t_end)
        if cmd is not None or not self.sees_commands:
            return cmd, []
        if kind == 'nic':
            return None, [ORPHAN.problem('NIC not right after an ACK')]
        return None, [ORPHAN.problem('no command awaits an ACK/NAK')]

    def answered_by(self, kind, t, t_end):
        self.expire(t)
        last, self.last_ack = self.last_ack, None
        if kind == 'nic':
            if last is not None:
                self.awaiting_result = [c for c in self.awaiting_result if c is not last]
            return last
        cmd, self.awaiting_ack = self.awaiting_ack, None
        if cmd is None:
            cmd, self.timed_out = self.timed_out, None   # a late ACK or NAK, or none
            return cmd
        if kind == 'ack':
            self.last_ack = cmd
            due = cmd['entry']['due'] if cmd['entry'] is not None else None
            if due in ('due', 'optional'):
                cmd['optional'] = due == 'optional'
                wait = cmd['entry']['result_timeout'] or RESULT_TIMEOUT
                cmd['deadline'] = t_end + wait if t_end is not None else None
                self.awaiting_result.append(cmd)
                if len(self.awaiting_result) > MAX_AWAITING:
                    del self.awaiting_result[0]
        return cmd

    def other(self, t=None):
        """An event that answers nothing (noise): it comes between an ACK and a NIC."""
        self.expire(t)
        self.last_ack = None

    def frame(self, line, raw, problems, t=None, t_end=None):
        """What a whole frame of ``line`` ('A', 'B' or 'AB') says: a dict of its
        kind, command code, device, summary, field values, the fields' spans in
        the payload and the problems the dissection found (``problems``: the
        deframing's and the line's, which the summary heeds)."""
        self.expire(t)
        self.last_ack = None
        dst, src, payload = (raw[1], raw[2], raw[3]), raw[4], raw[6:-1]
        kind = 'command' if line == 'A' else 'result' if line == 'B' else self.classify(dst, src, payload)
        if kind == 'command':
            entry, code, values, found, spans = dissect_command(payload)
            device = address(dst)
            text = command_summary(entry, values, problems + found, payload)
            self.command({'entry': entry, 'command': code, 'dst': dst, 'src': src, 'optional': False, 'age': 0,
                          'deadline': t_end + ACK_TIMEOUT if t_end is not None else None}, t is not None)
        else:
            device = address((src, dst[1], dst[2]))   # the sender: groups swapped back (Table 3)
            cmd, values, found, spans = self.result(dst, src, payload)
            if cmd is not None:
                code = cmd['command']
                text = result_summary(cmd['entry'], values, payload)
            else:
                code = '?'
                found = [ORPHAN.problem('no command awaits this result')] if self.sees_commands else []
                text = "'%s'" % payload_text(payload)
        return {'kind': kind, 'command': code, 'device': device, 'summary': text, 'values': values,
                'spans': spans, 'found': list(found)}

    def expire(self, t):
        """Time ``t`` has come: what waited past its timeout waits no more."""
        if t is None:
            return
        cmd = self.awaiting_ack
        if cmd is not None and cmd['deadline'] is not None and t > cmd['deadline']:
            self.awaiting_ack = None
            self.timed_out = cmd
        if self.awaiting_result:
            self.awaiting_result = [c for c in self.awaiting_result if c['deadline'] is None or t <= c['deadline']]

    def command(self, cmd, timed):
        self.timed_out = None
        keep = []
        for c in self.awaiting_result:
            c['age'] += 1
            if c['command'] == cmd['command'] and c['dst'] == cmd['dst']:
                continue   # sent again before its result came
            if not timed and c['age'] > UNTIMED_WINDOW:
                continue
            keep.append(c)
        self.awaiting_result = keep
        self.awaiting_ack = cmd

    def result(self, dst, src, payload):
        """(the command a result answers, its values, problems, spans), or Nones."""
        ack_cmd = self.awaiting_ack
        candidates = ([ack_cmd] if ack_cmd is not None else []) + self.awaiting_result[::-1]
        fallback = None
        for cand in candidates:
            if not address_fits(cand, dst, src):
                continue
            entry = cand['entry']
            if entry is not None and entry['results']:
                decoded = dissect_result(entry, payload)
                if decoded[0]:
                    return self.take(cand, decoded)
            if fallback is None and not cand['optional']:
                fallback = cand
        if fallback is None:
            return None, {}, [], []
        return self.take(fallback, dissect_result(fallback['entry'], payload))

    def take(self, cmd, decoded):
        if cmd is self.awaiting_ack:   # the ACK was lost, the result came
            self.awaiting_ack = None
        else:
            self.awaiting_result = [c for c in self.awaiting_result if c is not cmd]
        values, problems, spans = decoded
        return cmd, values, problems, spans

    def classify(self, dst, src, payload):
        """A single-line tap's frame: command or result (analysis.pairing._classify)."""
        for cmd in reversed(self.awaiting_result):
            if address_fits(cmd, dst, src) and result_fits(cmd['entry'], payload):
                return 'result'
        waiting = self.awaiting_ack
        if waiting is not None and waiting['dst'][0] != waiting['src'] and address_fits(waiting, dst, src) \
                and result_fits(waiting['entry'], payload):
            return 'result'
        groups = self.controller_groups
        if groups and src != dst[0]:
            if src in groups and dst[0] not in groups:
                return 'command'
            if dst[0] in groups and src not in groups:
                return 'result'
        if dissect_command(payload)[0] is None:
            return 'result'
        groups.add(src)
        return 'command'


# ---------------------------------------------------------------- deframing
def printable_share(data):
    return sum(1 for b in data if 0x20 <= b < 0x7F) / len(data) if data else 0.0


class LineDeframer:
    """One line's bytes into events, as dissectors.deframer.Deframer decides them.

    ``finish`` is called at a silence longer than the frame gap (and at a
    break), which no frame spans. Events go to ``emit(kind, first, end,
    problem)`` with absolute byte offsets, kind 'frame', 'noise', 'ack', 'nak'
    or 'nic'; ``self.base`` is the offset of ``self.buf[0]``."""

    def __init__(self, line, emit):
        self.line = line
        self.simple = line != 'A'        # ACK/NAK/NIC only travel device to controller
        self.emit = emit
        self.buf = bytearray()
        self.base = 0
        self.i = 0                        # where deframing resumes, in buf
        self.noise_start = None           # absolute offset of a pending noise run

    def feed(self, value):
        self.buf.append(value)
        self.deframe(False)

    def finish(self):
        self.deframe(True)

    def deframe(self, final):
        buf = self.buf
        n = len(buf)
        i = self.i
        while i < n:
            b = buf[i]
            if b == START:
                nxt = self.try_frame(i, final)
                if nxt is None:
                    break
                i = nxt
            elif self.simple and b in SIMPLE:
                self.flush_noise(i)
                self.emit(SIMPLE[b], self.base + i, self.base + i + 1, None)
                i += 1
            else:
                self.noise(i, i + 1)
                i += 1
        if final:
            self.flush_noise(n)
        keep = i if self.noise_start is None else min(i, self.noise_start - self.base)
        del buf[:keep]
        self.base += keep
        self.i = i - keep

    # offsets below are indexes into buf
    def checks(self, p, end):
        buf = self.buf
        return sum(buf[p + 1:end - 1]) & 0xFF == buf[end - 1]

    def valid_at(self, q, final):
        buf, n = self.buf, len(self.buf)
        need = q + 6 if n - q < 6 else q + (buf[q + 5] or 256) + 7
        if need > n:
            return -1 if final else None
        return need if self.checks(q, need) else -1

    def try_frame(self, p, final):
        buf, n = self.buf, len(self.buf)
        if n - p < 6:
            if not final:
                return None       # the header is still arriving
            return self.broken(p, n, TRUNCATED.problem('header cut after %d bytes' % (n - p)))
        length = buf[p + 5] or 256
        total = length + 7
        if n - p >= total:
            if self.checks(p, p + total):
                if buf.find(START, p + 6, p + total - 1) != -1:
                    # a start byte in an ASCII payload: the checksum may match by chance
                    q = self.frame_inside_suspect(p, total, final)
                    if q is None:
                        return None
                    if q >= 0:
                        return self.broken(p, q, CHECKSUM.problem(
                            'frame that only checks out by chance, resynchronised on the frame at offset %d'
                            % (self.base + q)))
                self.flush_noise(p)
                self.emit('frame', self.base + p, self.base + p + total, None)
                return p + total
        elif not final:
            return None           # the frame is still arriving
        return self.bad_frame(p, length, final)

    def frame_inside_suspect(self, p, total, final):
        buf = self.buf
        q = buf.find(START, p + 6, p + total - 1)
        while q != -1:
            v = self.valid_at(q, final)
            if v is None:
                return None
            if v > 0 or self.plausible_inside(q, p + total):
                return q
            q = buf.find(START, q + 1, p + total - 1)
        return -1

    def plausible_inside(self, q, end_limit):
        buf = self.buf
        if end_limit - q < 8:
            return False
        end = q + (buf[q + 5] or 256) + 7
        return end <= end_limit and printable_share(buf[q + 6:end - 1]) >= 0.75

    def bad_frame(self, p, length, final):
        buf, n = self.buf, len(self.buf)
        total = length + 7
        # 1. a valid frame starting inside it wins
        limit = min(p + total, n)
        q = buf.find(START, p + 1, limit)
        while q != -1:
            v = self.valid_at(q, final)
            if v is None:
                return None
            if v > 0:
                return self.before_resync(p, q, length)
            q = buf.find(START, q + 1, limit)
        # 2. the length byte was corrupted: an end before the next start byte checks out
        repaired = self.length_repair(p, length, final)
        if repaired is None:
            return None
        if repaired > 0:
            m = repaired - p - 7
            self.flush_noise(p)
            self.emit('frame', self.base + p, self.base + repaired, LENGTH.problem(
                'says %d, frame carries %d payload bytes (the checksum holds with %d)' % (length, m, m)))
            return repaired
        # 3. no better reading: a complete frame with a bad checksum, or a cut one
        if n >= p + total:
            return self.checksum_failed(p, total, final)
        return self.cut_short(p, total)

    def checksum_failed(self, p, total, final):
        buf, n = self.buf, len(self.buf)
        end = p + total
        if end < n:
            nxt = buf[end]
            bounded = nxt == START or (self.simple and nxt in SIMPLE)
        elif final:
            bounded = True        # a silence follows: the length byte held
        else:
            return None           # the next byte decides
        if not bounded and printable_share(buf[p + 6:end - 1]) < 0.75:
            return self.noise(p, p + 1)
        self.flush_noise(p)
        want = sum(buf[p + 1:end - 1]) & 0xFF
        self.emit('frame', self.base + p, self.base + end, CHECKSUM.problem(
            'expected 0x%02x, got 0x%02x' % (want, buf[end - 1])))
        return end

    def cut_short(self, p, total):
        n = len(self.buf)
        if printable_share(self.buf[p + 6:n]) < 0.75:
            return self.noise(p, p + 1)
        return self.broken(p, n, TRUNCATED.problem('%d of %d bytes, then silence' % (n - p, total)))

    def before_resync(self, p, q, length):
        buf = self.buf
        m = q - p - 7
        if 1 <= m <= 256 and printable_share(buf[p + 6:q - 1]) == 1.0:
            implied = (sum(buf[p + 1:p + 5]) + (m & 0xFF) + sum(buf[p + 6:q - 1])) & 0xFF
            if implied == buf[q - 1]:
                self.flush_noise(p)
                self.emit('frame', self.base + p, self.base + q, LENGTH.problem(
                    'says %d, frame carries %d payload bytes (the checksum holds with %d)' % (length, m, m)))
                return q
        return self.broken(p, q, CHECKSUM.problem(
            'broken frame, resynchronised on the frame at offset %d' % (self.base + q)))

    def length_repair(self, p, length, final):
        buf, n = self.buf, len(self.buf)
        hard = n if final else None
        stop = p + MAX_FRAME
        if hard is not None:
            stop = min(stop, hard)
        elif n < stop:
            return None           # not enough bytes yet to rule out every candidate end
        head = sum(buf[p + 1:p + 5])
        ends = []
        e = buf.find(START, p + 8, stop)
        while e != -1:
            ends.append(e)
            e = buf.find(START, e + 1, stop)
        if hard is not None and hard <= p + MAX_FRAME:
            ends.append(hard)
        for e in ends:
            m = e - p - 7
            if not 1 <= m <= 256 or m == length:
                continue
            payload = buf[p + 6:e - 1]
            if (head + (m & 0xFF) + sum(payload)) & 0xFF == buf[e - 1] and printable_share(payload) == 1.0:
                return e
        return 0

    def broken(self, p, stop, problem):
        """Bytes [p, stop) are a frame that cannot be read: one noise event."""
        self.flush_noise(p)
        self.emit('noise', self.base + p, self.base + stop, problem)
        return stop

    def noise(self, p, q):
        """Bytes [p, q) are noise: extend the pending run, cut every NOISE_PIECE bytes."""
        ns = self.noise_start if self.noise_start is not None else self.base + p
        while ns + NOISE_PIECE < self.base + q:
            self.noise_start = ns
            self.flush_noise(ns + NOISE_PIECE - self.base)
            ns += NOISE_PIECE
        self.noise_start = ns
        return q

    def flush_noise(self, upto):
        ns = self.noise_start
        if ns is not None and ns < self.base + upto:
            k = self.base + upto - ns
            self.emit('noise', ns, self.base + upto,
                      NOISE.problem('%d byte%s outside any frame' % (k, '' if k == 1 else 's')))
        self.noise_start = None
'''


def source() -> str:
    """The frame decoder, its tables filled in."""
    return fill(TEMPLATE, table_values())
