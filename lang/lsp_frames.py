"""The language server's base protocol on a byte stream: `Content-Length` frames of JSON-RPC
messages, read so that a bad frame costs one error and never the stream.

pygls' reader trusts every header: a length 10 bytes short or 50 long, or a header without
its blank line, left it out of step for good (it answered nothing after, not even
`shutdown`), and `Content-Length: 99999999999` was a MemoryError. This reader is fed bytes
(no I/O of its own, so it is tested byte by byte) and gives back what it found:

- a body that is JSON: the decoded value (`Received`);
- anything else (a bad header, a body that is not JSON, bytes between frames): `Unreadable`,
  which the server answers with a ParseError, then it looks for the next `Content-Length`
  header and goes on from there;
- a length over the limit: `Unreadable` at once; the body is skipped without being kept.

A length too long is found out without waiting for bytes that may never come: the body ends
before the next frame's header when that comes, and when nothing comes for a while (`idle`)
a body whose bytes so far are one whole JSON value is taken (a valid frame could only go on
with white space). A length too short cuts the body: a ParseError, then the next header.

`invalid_request` says what makes a decoded value no JSON-RPC request or notification.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from typing import Any

PARSE_ERROR = -32700
INVALID_REQUEST = -32600
METHOD_NOT_FOUND = -32601
INVALID_PARAMS = -32602
SERVER_NOT_INITIALIZED = -32002  # LSP's: a request before `initialize`

# A body above this is refused unread (an editor's largest message is a whole document;
# 2 MB scenes are 2 MB). Headers are a few short lines.
MAX_BODY = 64 * 1024 * 1024
MAX_HEADER = 8 * 1024

_LENGTH = re.compile(rb"content-length", re.IGNORECASE)
_HEADER_LINE = re.compile(rb"([!#$%&'*+.^_`|~0-9A-Za-z-]+)[ \t]*:[ \t]*(.*?)[ \t]*")
_TOKEN_START = re.compile(rb"[!#$%&'*+.^_`|~0-9A-Za-z-]")
_PARTIAL_HEADER = re.compile(rb"[!#$%&'*+.^_`|~0-9A-Za-z-]*(?:[ \t]*:[^\n]*)?|\r")
_SPACE = b" \t\r\n"
_KEEP = len(b"content-length") - 1  # bytes kept across chunks: the word may be cut
_TRIES = 8  # places a body that is not JSON may end (each a decode) before it is given up


@dataclass(frozen=True)
class Received:
    value: Any


@dataclass(frozen=True)
class Unreadable:
    reason: str


Event = Received | Unreadable


class FrameReader:
    """Feed it the stream's bytes as they come; each call gives back the events found."""

    def __init__(self, max_body: int = MAX_BODY) -> None:
        self.max_body = max_body
        self._buf = bytearray()
        self._need: int | None = None  # the body's length while one is being read
        self._scanned = 0  # how far the body read so far was searched for a header
        self._skip = 0  # bytes of a refused body still to pass over
        self._lost = False  # inside bad bytes already reported, no header found yet

    def feed(self, data: bytes) -> list[Event]:
        self._buf += data
        out: list[Event] = []
        while self._step(out):
            pass
        return out

    @property
    def held(self) -> int:
        """How many bytes the reader keeps (a refused body is not kept)."""
        return len(self._buf)

    def pending(self) -> bool:
        """Whether a message was cut off (the stream ended inside it)."""
        return self._need is not None or self._skip > 0 or bool(bytes(self._buf).strip(_SPACE))

    # ---------------------------------------------------------------- states
    def _step(self, out: list[Event]) -> bool:
        """Make one step of progress; False when more bytes are needed."""
        if self._skip:
            return self._skip_body()
        if self._need is not None:
            return self._body(out)
        return self._header(out)

    def _resync(self, out: list[Event], reason: str, start: int = 1) -> bool:
        """Report the bytes from here to the next `Content-Length` as one ParseError (once
        per run of bad bytes, however many chunks it spans) and drop them."""
        if not self._lost:
            out.append(Unreadable(reason))
        found = _LENGTH.search(self._buf, start)
        if found is None:
            self._lost = True
            # keep a tail that could be the start of the word, cut by the chunk
            del self._buf[: max(len(self._buf) - _KEEP, 0)]
            return False
        self._lost = False
        del self._buf[: found.start()]
        return True

    def _header(self, out: list[Event]) -> bool:
        i = 0
        while i < len(self._buf) and self._buf[i] in _SPACE:
            i += 1
        del self._buf[:i]  # blank lines between frames are harmless
        if not self._buf:
            return False
        if self._lost:  # what is kept of bad bytes (the word may be cut) is no header
            return self._resync(out, "", 0)
        if not _TOKEN_START.match(self._buf):
            return self._resync(out, "bytes outside a frame (no Content-Length header)", 0)
        headers: dict[bytes, bytes] = {}
        pos = 0
        while True:
            end = self._buf.find(b"\n", pos)
            if end < 0:
                # a line still coming: it must be able to become a header, and be short
                if len(self._buf) > MAX_HEADER or not _PARTIAL_HEADER.fullmatch(self._buf, pos):
                    return self._resync(out, "a header line that is not `Name: value`", pos + 1)
                return False
            line, start, pos = bytes(self._buf[pos:end]).rstrip(b"\r"), pos, end + 1
            if not line:
                break  # the blank line: the body follows
            m = _HEADER_LINE.fullmatch(line)
            if m is None or pos > MAX_HEADER:
                return self._resync(out, "a header line that is not `Name: value`", start + 1)
            headers[m.group(1).lower()] = m.group(2)
        length = headers.get(b"content-length")
        if length is None or not length.isdigit():
            # the frame's own header may hide in a line of bad bytes before it
            why = "a frame without Content-Length" if length is None else "a bad Content-Length"
            return self._resync(out, why, 1)
        del self._buf[:pos]
        n = int(length)
        if n > self.max_body:
            out.append(Unreadable(f"a message of {n} bytes (the limit is {self.max_body})"))
            self._skip = n
            return True
        self._need, self._scanned, self._lost = n, 0, False
        return True

    def _body(self, out: list[Event]) -> bool:
        n = self._need
        assert n is not None
        if len(self._buf) < n:
            return self._early(out)
        body = bytes(self._buf[:n])
        try:
            out.append(Received(_decode(body)))
            return self._done(n)
        except ValueError:
            pass
        # a length too long: the body ran into the next frame's header
        for found in list(_LENGTH.finditer(body, 1))[:_TRIES]:
            try:
                out.append(Received(_decode(body[: found.start()])))
                return self._done(found.start())
            except ValueError:
                continue
        first = _LENGTH.search(body, 1)
        out.append(Unreadable("a body that is not JSON (or a Content-Length that is wrong)"))
        self._lost = True  # what is left of a body cut short is part of the same error
        return self._done(first.start() if first is not None else n)

    def _early(self, out: list[Event]) -> bool:
        """The body is not all here: if the next frame's header is, the length was too long
        and the body ends before it (when what is before it is a whole JSON value)."""
        start, self._scanned = max(self._scanned - _KEEP, 1), len(self._buf)
        for found in list(_LENGTH.finditer(self._buf, start))[:_TRIES]:
            try:
                out.append(Received(_decode(bytes(self._buf[: found.start()]))))
                return self._done(found.start())
            except ValueError:
                continue
        return False

    def waiting(self) -> bool:
        """Whether a body is being read and is not all here."""
        return self._need is not None

    def idle(self) -> list[Event]:
        """No bytes came for a while (the caller's clock): a body not all here is taken if
        what is here is a whole JSON value, as only white space could follow it in a valid
        frame. So a length too long gets its answer without bytes that never come; one
        decode per pause, not one per chunk (a 20 MB body in 4 KB chunks took 10 s)."""
        if self._need is None:
            return []
        end = len(self._buf)
        while end and self._buf[end - 1] in _SPACE:
            end -= 1
        if not end or self._buf[end - 1] not in b"}]":
            return []
        try:
            value = _decode(bytes(self._buf[:end]))
        except ValueError:
            return []
        self._done(end)
        out: list[Event] = [Received(value)]
        while self._step(out):
            pass
        return out

    def _done(self, used: int) -> bool:
        """The body took the first `used` bytes; a header comes next."""
        self._need = None
        del self._buf[:used]
        return True

    def _skip_body(self) -> bool:
        """Pass over a refused body without keeping it; a `Content-Length` inside it is
        taken as the next frame (the length was a lie, not a body)."""
        found = _LENGTH.search(self._buf, 0, min(self._skip, len(self._buf)))
        if found is not None:
            self._skip = 0
            del self._buf[: found.start()]
            return True
        if self._skip <= len(self._buf):
            del self._buf[: self._skip]
            self._skip = 0
            return True
        drop = max(len(self._buf) - _KEEP, 0)
        self._skip -= drop
        del self._buf[:drop]
        return False


def _decode(body: bytes) -> Any:
    """The JSON value a body holds (ValueError if it holds none, or more than one, or is
    nested past Python's frames: `[[[…]]]` 100,000 deep was a RecursionError)."""
    try:
        return json.loads(body.decode("utf-8"))
    except RecursionError:
        raise ValueError("JSON nested too deeply") from None


def invalid_request(value: Any) -> str | None:
    """What makes `value` no JSON-RPC 2.0 request, notification or response, or None."""
    if not isinstance(value, dict):
        return f"a JSON-RPC message is an object, not {type(value).__name__}"
    if value.get("jsonrpc") != "2.0":
        return 'a JSON-RPC message has "jsonrpc": "2.0"'
    if "id" in value and not _is_id(value["id"]):
        return "a message id is a number, a string or null"
    if "method" in value:
        if not isinstance(value["method"], str):
            return "a method name is a string"
        if "params" in value and not isinstance(value["params"], dict | list):
            return "params are an object or an array"
        return None
    if "id" in value and ("result" in value or "error" in value):
        return None  # a response to a request of the server's
    return "a JSON-RPC message has a method (or is a response with an id)"


def request_id(value: Any) -> int | str | None:
    """The id an error about `value` answers: its own when it has a valid one, else null."""
    if isinstance(value, dict) and "id" in value and _is_id(value["id"]):
        return value["id"]
    return None


def _is_id(v: Any) -> bool:
    return v is None or (isinstance(v, int | str) and not isinstance(v, bool))


def error_frame(msg_id: int | str | None, code: int, message: str) -> bytes:
    """A framed JSON-RPC error response."""
    body = json.dumps(
        {"jsonrpc": "2.0", "id": msg_id, "error": {"code": code, "message": message}}
    ).encode()
    return b"Content-Length: %d\r\n\r\n" % len(body) + body
