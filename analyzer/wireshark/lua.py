"""The Wireshark dissector for protocol ``gimbal``, generated in Lua from the
command table (``dissectors.commands``: every command, field and result layout
of Tables 4-18) and the problem table (``dissectors.problems``: one expert
info each). docs/wireshark.md says what it shows and why.

What the generated dissector does itself, and what it reads from the packet
(``analyzer.formats.pdu``):

- **decodes every field from the wire bytes**: each layout becomes a Lua
  pattern with a capture per field, and each field's codec (hex with its
  divisor and sign, decimal, text, choice) is written out as data; the values
  the table derives (a rate code's ``baud``, bit names, flags) are the small
  Lua functions of ``_DERIVES``, one per derive function of the table;
- **reads the pairing from the packet** (transaction, status, latency, the
  command a result answers, the layout it matched, the problems): pairing
  rules (timeouts per command, retransmissions, late and orphan answers, which
  frame of a single-line tap is a command) are the analyzer's, and a second
  implementation in Lua would drift from it;
- **links frames in Lua**: ``request_in`` and ``response_in`` are Wireshark
  frame numbers, found from the transaction numbers as the file is read, so
  they stay right in a file cut or merged with editcap or mergecap.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from dissectors import problems as P
from dissectors.commands import BAUD_CODES, COMMANDS, DERIVED, ERROR_BITS, STATUS_BITS, field_types
from dissectors.fields import Field, Layout

from ..formats import pdu
from ..templates import fill
from ..version import __version__

# Names of the dissector's own fields; a decoded field with one of these names is
# ``field_<name>`` (the AW result's ``status``), as in the fleet dataset.
FIXED = ("kind", "command", "command_name", "dst", "src", "device", "checksum_ok", "checksum", "length",
         "payload", "status", "latency", "request_in", "response_in", "txn", "number", "request", "line",
         "retransmission", "problem", "capture", "spec")

# a problem category -> its expert info group (Wireshark's expert.group)
EXPERT_GROUPS = {
    "CHECKSUM": "CHECKSUM", "LENGTH": "MALFORMED", "TRUNCATED": "MALFORMED", "NOISE": "UNDECODED",
    "MALFORMED": "MALFORMED", "OUT_OF_RANGE": "PROTOCOL", "RESERVED": "PROTOCOL",
    "LOWERCASE_HEX": "PROTOCOL", "UNKNOWN_COMMAND": "UNDECODED", "UNANSWERED": "SEQUENCE",
    "NO_RESULT": "SEQUENCE", "RETRANSMISSION": "SEQUENCE", "ORPHAN": "SEQUENCE", "LATE": "SEQUENCE",
    "LINE": "MALFORMED",   # the bytes were damaged on the wire (framing, parity, break, overrun)
}
EXPERT_SEVERITY = {P.ERROR: "ERROR", P.WARNING: "WARN", P.NOTE: "NOTE"}

# The table's derive functions (dissectors/commands.py), in Lua: ``v`` holds the
# layout's decoded values by field name, and gets the derived ones.
_DERIVES = {
    "_baud": "function(v) v.baud = BAUD_CODES[v.rate_code] end",
    "_max_baud": "function(v) v.max_baud = BAUD_CODES[v.max_rate_code] end",
    "_awake": """function(v)
    local s = v.status
    v.azimuth_not_initialized = bit(s, 0)
    v.elevation_not_initialized = bit(s, 1)
    v.motors_off = bit(s, 2)
    v.error = bit(s, 3)
  end""",
    "_errors": """function(v)
    v.azimuth_errors = bit_names(v.azimuth_error_bits, ERROR_BITS)
    v.elevation_errors = bit_names(v.elevation_error_bits, ERROR_BITS)
  end""",
    "_status": """function(v)
    v.azimuth_status = bit_names(v.azimuth_status_bits, STATUS_BITS)
    v.elevation_status = bit_names(v.elevation_status_bits, STATUS_BITS)
  end""",
    "_relays": """function(v)
    local on = {}
    for k = 0, 3 do if bit(v.relays, k) then on[#on + 1] = k end end
    v.relays_on = on
  end""",
    "_init_results": """function(v)
    for _, key in ipairs({"azimuth_ccw", "azimuth_cw", "elevation_ccw", "elevation_cw"}) do
      local r = v[key .. "_result"]
      v[key .. "_ok"] = bit(r, 0) and not bit(r, 2) and bit(r, 3)
    end
  end""",
    "_home": """function(v)
    v.azimuth_initialized = bit(v.count_correct_bits, 0)
    v.elevation_initialized = bit(v.count_correct_bits, 1)
  end""",
    "_aux_data": "function(v) v.data_length = #v.data end",
}


def lua_string(text: str | bytes) -> str:
    """A Lua string literal of ``text`` (bytes as they are; str as UTF-8)."""
    data = text.encode("utf-8") if isinstance(text, str) else text
    out = []
    for b in data:
        c = chr(b)
        if c in '\\"':
            out.append("\\" + c)
        elif 0x20 <= b < 0x7F:
            out.append(c)
        else:
            out.append(f"\\{b:03d}")
    return '"' + "".join(out) + '"'


def abbr(name: str) -> str:
    """The display-filter name of a decoded field."""
    return f"gimbal.field_{name}" if name in FIXED else f"gimbal.{name}"


_CLASSES = {rb"[0-9A-Fa-f]": "%x", rb"[0-9]": "%d", rb"[\s\S]": ".", rb".": ".", rb"[A-Fa-f]": "[A-Fa-f]"}
_PART = re.compile(rb"(\[[^\]]+\]|\.)(?:\{(\d+)(?:(,)(\d*))?\})?")
_LUA_MAGIC = re.compile(r"([\^$()%.\[\]*+\-?])")


def lua_pattern(regex: bytes) -> str:
    """A field's regular expression as a Lua pattern: the few shapes the table
    uses (a class, repeated n, n..m or n or more times); anything else raises,
    so a new shape in the table fails the generator rather than the dissector."""
    m = _PART.fullmatch(regex)
    if m is None or m.group(1) not in _CLASSES:
        raise ValueError(f"no Lua pattern for field regex {regex!r}")
    cls = _CLASSES[m.group(1)]
    if m.group(2) is None:
        return cls
    low = int(m.group(2))
    if m.group(3) is None:
        return cls * low
    if m.group(4) == b"":          # n or more
        return cls * low + cls + "*"
    return cls * low + (cls + "?") * (int(m.group(4)) - low)


def layout_pattern(layout: Layout) -> str:
    """The anchored Lua pattern of a layout: a position and a value capture per field."""
    out = ["^"]
    for part in layout.parts:
        if isinstance(part, bytes):
            out.append(_LUA_MAGIC.sub(r"%\1", part.decode("latin-1")))
        else:
            out.append("()(" + lua_pattern(part.regex) + ")")
    out.append("$")
    return "".join(out)


def _field_spec(f: Field) -> str:
    items = [f"n = {lua_string(f.name)}", f"c = {lua_string(f.codec)}"]
    if f.divisor is not None:
        items.append(f"d = {f.divisor}")
    if f.signed:
        items.append("s = true")
    if f.strip:
        items.append("strip = true")
    if f.codec == "choice":
        pairs = ", ".join(f"[{lua_string(k)}] = {_lua_value(v)}" for k, v in f.choices)
        items.append(f"map = {{{pairs}}}")
    return "{" + ", ".join(items) + "}"


def _lua_value(v: object) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    return lua_string(str(v))


def _derive_name(layout: Layout) -> str | None:
    fn = layout.derive
    if fn is None:
        return None
    name = fn.__name__
    if name not in _DERIVES:
        raise ValueError(f"derive function {name} of the command table has no Lua version in {__name__}")
    return name


def layout_spec(layout: Layout) -> str:
    """A layout as the dissector's Lua table: its pattern, fields and derive function."""
    fields = ", ".join(_field_spec(f) for f in layout.fields)
    derive = _derive_name(layout)
    spec = f"{{p = {lua_string(layout_pattern(layout))}, f = {{{fields}}}"
    return spec + (f", derive = DERIVE.{derive}}}" if derive else "}")


def _commands() -> str:
    lines = []
    for i, c in enumerate(COMMANDS, 1):
        layouts = [f"[0] = {layout_spec(c.layout)}"] + [f"[{k}] = {layout_spec(r)}"
                                                         for k, r in enumerate(c.result, 1)]
        lines.append(f"  [{i}] = {{id = {lua_string(c.id)}, name = {lua_string(c.name)}, "
                     f"ref = {lua_string(c.ref)},\n         layouts = {{{', '.join(layouts)}}}}},")
    return "\n".join(lines)


_PROTOFIELD = {"integer": "int32", "number": "double", "string": "string", "boolean": "bool"}


def _value_fields() -> str:
    out = []
    for name, ft in field_types().items():
        kind = _PROTOFIELD[ft.items or ft.type]
        desc = ft.desc + (f" [{ft.unit}]" if ft.unit else "")
        extra = ", base.DEC" if kind == "int32" else ""
        if kind == "bool":
            extra = ", base.NONE"
        unit = lua_string(" " + ft.unit) if ft.unit else '""'
        if kind in ("int32", "bool"):     # (abbr, name, base, valuestring, mask, desc)
            args = f"{extra}, nil, nil, {lua_string(desc)}"
        elif kind == "string":            # (abbr, name, display, desc)
            args = f", base.ASCII, {lua_string(desc)}"
        else:                             # (abbr, name, desc)
            args = f", {lua_string(desc)}"
        out.append(f"  [{lua_string(name)}] = {{pf = ProtoField.{kind}({lua_string(abbr(name))}, "
                   f"{lua_string(name)}{args}), unit = {unit}}},")
    return "\n".join(out)


def _experts() -> str:
    out = []
    for i, info in enumerate(P.TABLE):
        group = EXPERT_GROUPS[info.category.name]
        out.append(f"  [{i}] = ProtoExpert.new({lua_string('gimbal.expert.' + info.name.lower())}, "
                   f"{lua_string(info.text + ': ' + info.summary)}, expert.group.{group}, "
                   f"expert.severity.{EXPERT_SEVERITY[info.severity]}),")
    return "\n".join(out)


def _codes(values: Iterable[str | None]) -> str:
    return "{" + ", ".join(f"[{i}] = {lua_string(v)}" for i, v in enumerate(values) if v is not None) + "}"


def generate() -> str:
    """The dissector's Lua source."""
    subs = {
        "VERSION": __version__,
        "KINDS": _codes(pdu.KIND_CODES),
        "STATUSES": _codes(pdu.STATUS_CODES),
        "LINES": _codes(pdu.LINE_CODES),
        "BAUD_CODES": "{" + ", ".join(f"[{k}] = {v}" for k, v in BAUD_CODES.items()) + "}",
        "ERROR_BITS": "{" + ", ".join(f"{{{b}, {lua_string(n)}}}" for b, n in ERROR_BITS.items()) + "}",
        "STATUS_BITS": "{" + ", ".join(f"{{{b}, {lua_string(n)}}}" for b, n in STATUS_BITS.items()) + "}",
        "DERIVES": "\n".join(f"DERIVE.{name} = {code}" for name, code in _DERIVES.items()),
        "DERIVED_ORDER": "{" + ", ".join(lua_string(d.name) for d in DERIVED) + "}",
        "VALUE_FIELDS": _value_fields(),
        "EXPERTS": _experts(),
        "COMMANDS": _commands(),
        "LINKTYPE": str(pdu.LINKTYPE),
        "HEADER_VERSION": str(pdu.VERSION),
        "NO_LAYOUT": str(pdu.NO_LAYOUT),
        "NO_PAYLOAD": str(pdu.NO_PAYLOAD),
    }
    return fill(_TEMPLATE, subs)


_TEMPLATE = r'''-- gimbal.lua: Wireshark dissector for the gimbal serial protocol (rev 1.9),
-- generated by gimbalscope @@VERSION@@ from its command table. Do not edit:
-- `gimbalscope wireshark install` writes it anew.
--
-- It reads the packets gimbalscope writes (export -o FILE.pcapng, and the extcap
-- live capture): link type @@LINKTYPE@@ (exported PDU) naming the dissector
-- "gimbal", then gimbalscope's header (the pairing and the problems), then the
-- bytes as they were on the wire, which this dissector decodes.

local gimbal = Proto("gimbal", "Gimbal serial protocol (rev 1.9)")

local KINDS = @@KINDS@@
local STATUSES = @@STATUSES@@
local LINES = @@LINES@@
local BAUD_CODES = @@BAUD_CODES@@
local ERROR_BITS = @@ERROR_BITS@@
local STATUS_BITS = @@STATUS_BITS@@
local NO_LAYOUT, NO_PAYLOAD = @@NO_LAYOUT@@, @@NO_PAYLOAD@@
local RETRANSMISSION, CHECKSUM_KNOWN, CHECKSUM_OK, HAS_LATENCY, HAS_DEVICE = 1, 2, 4, 8, 16

-- bit k of v (arithmetic: Lua 5.2 to 5.4 without a bit library)
local function bit(v, k) return math.floor(v / 2 ^ k) % 2 == 1 end
local function has(flags, f) return flags % (2 * f) >= f end   -- f: one flag bit
local function bit_names(v, tbl)
  local out = {}
  for _, e in ipairs(tbl) do if bit(v, e[1]) then out[#out + 1] = e[2] end end
  return out
end

local DERIVE = {}
@@DERIVES@@
local DERIVED_ORDER = @@DERIVED_ORDER@@

-- the command table: for each command its parameters' layout [0] and its
-- result layouts [1..]: a pattern with a position and a value capture per field
local COMMANDS = {
@@COMMANDS@@
}

-- ---------------------------------------------------------------- fields
local fr = frametype or {}
local hf = {
  kind = ProtoField.string("gimbal.kind", "Kind", base.ASCII, "command, result, ack, nak, nic, noise (frame: not yet paired)"),
  line = ProtoField.string("gimbal.line", "Line", base.ASCII, "A controller to device, B device to controller, AB both"),
  number = ProtoField.uint32("gimbal.number", "Event number", base.DEC, nil, nil, "gimbalscope's event number (JSON Lines number)"),
  capture = ProtoField.uint16("gimbal.capture", "Capture", base.DEC, nil, nil, "which capture of the file"),
  device = ProtoField.string("gimbal.device", "Device", base.ASCII, "the gimbal, group.port.device"),
  command = ProtoField.string("gimbal.command", "Command", base.ASCII, "the command id; on a result, the command it answers"),
  command_name = ProtoField.string("gimbal.command_name", "Command name"),
  spec = ProtoField.string("gimbal.spec", "Spec reference"),
  status = ProtoField.string("gimbal.status", "Status", base.ASCII, "commands: ok, nak, nic, no_ack, no_result, pending"),
  txn = ProtoField.uint32("gimbal.txn", "Transaction", base.DEC, nil, nil, "shared by a command and its answers"),
  request = ProtoField.uint32("gimbal.request", "Request event", base.DEC, nil, nil, "answers: the command's event number"),
  request_in = ProtoField.framenum("gimbal.request_in", "Request In", base.NONE, fr.REQUEST, nil, "the frame of the command this answers"),
  response_in = ProtoField.framenum("gimbal.response_in", "Response In", base.NONE, fr.RESPONSE, nil, "a frame answering this command"),
  latency = ProtoField.relative_time("gimbal.latency", "Latency", "answers: from the command's last byte to the answer's first"),
  retransmission = ProtoField.bool("gimbal.retransmission", "Retransmission", base.NONE, nil, nil, "resends a command that failed"),
  dst = ProtoField.string("gimbal.dst", "Destination", base.ASCII, "group.port.device as the header has it"),
  dst_group = ProtoField.uint8("gimbal.dst.group", "Group", base.DEC),
  dst_port = ProtoField.uint8("gimbal.dst.port", "Port", base.DEC),
  dst_device = ProtoField.uint8("gimbal.dst.device", "Device", base.DEC),
  src = ProtoField.uint8("gimbal.src", "Source group", base.DEC),
  length = ProtoField.uint8("gimbal.length", "Length", base.DEC, nil, nil, "payload length; 0 means 256"),
  payload = ProtoField.string("gimbal.payload", "Payload"),
  checksum = ProtoField.uint8("gimbal.checksum", "Checksum", base.HEX),
  checksum_ok = ProtoField.bool("gimbal.checksum_ok", "Checksum OK", base.NONE),
  problem = ProtoField.string("gimbal.problem", "Problem", base.ASCII, "category: detail"),
  wire = ProtoField.bytes("gimbal.wire", "Wire bytes"),
}

-- one field per decoded value of the command table
local VALUES = {
@@VALUE_FIELDS@@
}

local EXPERTS = {
@@EXPERTS@@
}
local ef_header = ProtoExpert.new("gimbal.expert.header", "not a gimbalscope packet header this dissector knows",
                                  expert.group.MALFORMED, expert.severity.ERROR)

local fields = {}
for _, f in pairs(hf) do fields[#fields + 1] = f end
for _, v in pairs(VALUES) do fields[#fields + 1] = v.pf end
gimbal.fields = fields
local experts = {ef_header}
for _, e in pairs(EXPERTS) do experts[#experts + 1] = e end
gimbal.experts = experts

-- ---------------------------------------------------------------- decoding
local function strip(s) return (s:gsub("^%s+", ""):gsub("%s+$", "")) end

local function decode(spec, s)
  local c = spec.c
  if c == "hex" then
    local n = tonumber(s, 16)
    if spec.s and n >= 0x8000 then n = n - 0x10000 end
    if spec.d then n = n / spec.d end
    return n
  elseif c == "decimal" then
    return tonumber(s, 10)
  elseif c == "choice" then
    return spec.map[s]
  end
  if spec.strip then return strip(s) end
  return s
end

local function add_value(tree, name, range, value)
  local v = VALUES[name]
  if v == nil or value == nil then return end
  local item = tree:add(v.pf, range, value)
  if v.unit ~= "" then item:append_text(v.unit) end
  return item
end

-- the decoded values of `payload` (wire range `prange`) by `layout`, added to `tree`
local function add_fields(tree, layout, prange)
  local payload = prange:raw()
  local caps = {payload:match(layout.p)}
  if #caps == 0 then return nil end
  local v, spans = {}, {}
  for i, spec in ipairs(layout.f) do
    local at, s = caps[2 * i - 1], caps[2 * i]
    v[spec.n] = decode(spec, s)
    spans[spec.n] = {at - 1, #s}
  end
  if layout.derive then layout.derive(v) end
  local sub = tree:add(gimbal, prange, "Decoded values")
  for _, spec in ipairs(layout.f) do
    local span = spans[spec.n]
    add_value(sub, spec.n, prange:range(span[1], span[2]), v[spec.n])
  end
  for _, name in ipairs(DERIVED_ORDER) do
    local value = v[name]
    if value ~= nil and spans[name] == nil then
      if type(value) == "table" then
        for _, item in ipairs(value) do add_value(sub, name, prange, item):set_generated() end
      else
        add_value(sub, name, prange, value):set_generated()
      end
    end
  end
  return v
end

-- ---------------------------------------------------------------- pairing links
-- Filled on the first pass through the file, read on every later dissection.
-- Flat tables of numbers keyed by (capture, transaction) as one number: a table
-- per transaction would cost the garbage collector dearly over a day's capture.
local MAX_ANSWERS = 8
local cmd_frame, answer_count, answer_frame = {}, {}, {}
function gimbal.init() cmd_frame, answer_count, answer_frame = {}, {}, {} end

-- the command's frame number and the key of its answers, for a transaction
local function link(pinfo, kind, capture, txn)
  if txn == 0 then return nil, nil end
  local key = capture * 4294967296 + txn
  if not pinfo.visited then
    local number = pinfo.number
    if kind == "command" then
      cmd_frame[key] = number
      answer_count[key] = 0
    else
      local n = answer_count[key]
      if n ~= nil and n < MAX_ANSWERS then
        answer_frame[key * MAX_ANSWERS + n] = number
        answer_count[key] = n + 1
      end
    end
  end
  return cmd_frame[key], key
end

-- ---------------------------------------------------------------- the dissector
function gimbal.dissector(tvb, pinfo, tree)
  local cols = pinfo.cols
  cols.protocol = "GIMBAL"
  local root = tree:add(gimbal, tvb())
  if tvb:len() < 39 or tvb(0, 1):uint() ~= @@HEADER_VERSION@@ then
    root:add_proto_expert_info(ef_header)
    return
  end
  local kind = KINDS[tvb(1, 1):uint()] or "?"
  local status = STATUSES[tvb(2, 1):uint()]
  local flags = tvb(3, 1):uint()
  local number, txn, request = tvb(4, 4):uint(), tvb(8, 4):uint(), tvb(12, 4):uint()
  local capture = tvb(16, 2):uint()
  local line = LINES[tvb(18, 1):uint()] or "?"
  local layout_no = tvb(19, 1):uint()
  local entry = COMMANDS[tvb(28, 2):uint()]
  local p_at, p_len = tvb(30, 2):uint(), tvb(32, 2):uint()
  local n = tvb(37, 1):uint()
  local command = n > 0 and tvb(38, n):string() or nil
  local pos = 38 + n
  local problems = {}
  local count = tvb(pos, 1):uint()
  pos = pos + 1
  for _ = 1, count do
    local k = tvb(pos + 2, 2):uint()
    problems[#problems + 1] = {id = tvb(pos, 2):uint(), text = tvb(pos + 4, k):string(ENC_UTF_8), at = pos}
    pos = pos + 4 + k
  end
  local len = tvb:len() - pos   -- the wire bytes: tvb(pos, len)
  local function w(at, n) return tvb(pos + at, n) end

  local device
  if has(flags, HAS_DEVICE) then
    device = string.format("%d.%d.%d", tvb(34, 1):uint(), tvb(35, 1):uint(), tvb(36, 1):uint())
  end
  local cmd, key = link(pinfo, kind, capture, txn)

  -- the summary line and the columns
  root:append_text(string.format(", %s %s", kind, command or ""))
  if device then root:append_text((kind == "command" and " to " or " from ") .. device) end
  if status then root:append_text(" (" .. status .. ")") end
  if kind == "command" then
    cols.src = "controller"
    if device then cols.dst = device end
  elseif device then
    cols.src = device
    cols.dst = "controller"
  end
  local info = string.format("%s %-7s %s", line, kind, command or "")
  if status then info = info .. " [" .. status .. "]" end
  if request > 0 then info = info .. " #" .. request end
  if has(flags, HAS_LATENCY) then
    info = info .. string.format(" %.1f ms", tvb(20, 8):int64():tonumber() / 1e6)
  end
  if #problems > 0 then info = info .. " ! " .. problems[1].text end
  cols.info = info

  -- what gimbalscope decided (the header)
  root:add(hf.kind, tvb(1, 1), kind)
  root:add(hf.line, tvb(18, 1), line)
  root:add(hf.number, tvb(4, 4))
  if capture > 0 then root:add(hf.capture, tvb(16, 2)) end
  if device then root:add(hf.device, tvb(34, 3), device) end
  if command then
    root:add(hf.command, tvb(38, n), command)
    if entry then
      root:add(hf.command_name, tvb(28, 2), entry.name):set_generated()
      root:add(hf.spec, tvb(28, 2), entry.ref):set_generated()
    end
  end
  if status then root:add(hf.status, tvb(2, 1), status) end
  if txn > 0 then root:add(hf.txn, tvb(8, 4)) end
  if request > 0 then root:add(hf.request, tvb(12, 4)) end
  if cmd ~= nil then
    if kind == "command" then
      for k = 0, answer_count[key] - 1 do
        root:add(hf.response_in, tvb(8, 4), answer_frame[key * MAX_ANSWERS + k]):set_generated()
      end
    elseif cmd < pinfo.number then
      root:add(hf.request_in, tvb(8, 4), cmd):set_generated()
    end
  end
  if has(flags, HAS_LATENCY) then
    local ns = tvb(20, 8):int64():tonumber()
    root:add(hf.latency, tvb(20, 8), NSTime(math.floor(ns / 1e9), ns % 1e9))
  end
  if kind == "command" then root:add(hf.retransmission, tvb(3, 1), has(flags, RETRANSMISSION)) end

  -- the wire bytes
  local wt = root:add(hf.wire, tvb(pos, len))
  if p_at ~= NO_PAYLOAD and len >= 5 and w(0, 1):uint() == 0xF8 then
    local g, p, d = w(1, 1):uint(), w(2, 1):uint(), w(3, 1):uint()
    local dt = wt:add(hf.dst, w(1, 3), string.format("%d.%d.%d", g, p, d))
    dt:add(hf.dst_group, w(1, 1))
    dt:add(hf.dst_port, w(2, 1))
    dt:add(hf.dst_device, w(3, 1))
    wt:add(hf.src, w(4, 1))
    if len >= 6 then wt:add(hf.length, w(5, 1)) end
    if p_len > 0 and p_at + p_len <= len then
      local prange = w(p_at, p_len)
      wt:add(hf.payload, prange)
      if p_at + p_len < len then wt:add(hf.checksum, w(p_at + p_len, 1)) end
      if entry and layout_no ~= NO_LAYOUT and entry.layouts[layout_no] then
        add_fields(root, entry.layouts[layout_no], prange)
      end
    end
  end
  if has(flags, CHECKSUM_KNOWN) then
    wt:add(hf.checksum_ok, tvb(3, 1), has(flags, CHECKSUM_OK)):set_generated()
  end

  -- problems: a field each (for filters) and an expert info each
  for _, p in ipairs(problems) do
    local item = root:add(hf.problem, tvb(p.at + 4, #p.text), p.text)
    local e = EXPERTS[p.id]
    if e then item:add_proto_expert_info(e, p.text) end
  end
  return tvb:len()
end
'''
