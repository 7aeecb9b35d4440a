"""The language server's frame reader (lang.lsp_frames), fed bytes directly: every valid
frame after a bad one is read, however the stream is cut into chunks. Before, pygls' reader
stayed out of step for good after a Content-Length 10 bytes short or 50 long, or a header
without its blank line."""

from __future__ import annotations

import json
import time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lang.lsp_frames import (
    FrameReader,
    Received,
    Unreadable,
    invalid_request,
    request_id,
)


def frame(value: object, delta: int = 0, blank: bool = True) -> bytes:
    body = value if isinstance(value, bytes) else json.dumps(value).encode()
    head = f"Content-Length: {len(body) + delta}\r\n" + ("\r\n" if blank else "")
    return head.encode() + body


def request(i: int, text: str = "x") -> dict:
    return {"jsonrpc": "2.0", "id": i, "method": "m", "params": {"t": text}}


def read(data: bytes, cuts: list[int] | None = None, **kw) -> list[object]:
    reader = FrameReader(**kw)
    out: list[object] = []
    start = 0
    for cut in sorted(cuts or []) + [len(data)]:
        out += reader.feed(data[start:cut])
        start = max(start, cut)
    return out


def received(events: list[object]) -> list[object]:
    return [e.value for e in events if isinstance(e, Received)]


def test_valid_frames_are_read_in_order():
    data = frame(request(1)) + frame(request(2, "é ü")) + b"\r\n" + frame(request(3))
    assert received(read(data)) == [request(1), request(2, "é ü"), request(3)]


# each bad frame, then the reader must be in step again: (bytes, ParseErrors, lost message)
BAD = {
    "10 bytes short": (frame(request(7, "a" * 40), -10), 1),
    "50 bytes long": (frame(request(7), 50), 0),  # the message itself is read
    "no length": (b"Content-Type: x\r\n\r\n" + json.dumps(request(7)).encode(), 1),
    "length not a number": (b"Content-Length: ab\r\n\r\n{}", 1),
    "no blank line": (frame(request(7), 0, blank=False), 1),
    "not JSON": (b"Content-Length: 9\r\n\r\nnot json!", 1),
    "no header at all": (json.dumps(request(7)).encode(), 1),
    "random bytes": (bytes(range(256)) * 3, 1),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_a_bad_frame_costs_one_error_and_the_next_frame_is_read(name):
    bad, errors = BAD[name]
    events = read(bad + frame(request(1)) + frame(request(2)))
    assert len([e for e in events if isinstance(e, Unreadable)]) == errors, events
    assert received(events)[-2:] == [request(1), request(2)]
    if name == "50 bytes long":
        assert received(events) == [request(7), request(1), request(2)]
    # the error is there at once: nothing waits for bytes a stalled client never sends
    alone = read(bad)
    assert len([e for e in alone if isinstance(e, Unreadable)]) == errors


def test_a_length_too_long_is_answered_without_waiting_for_more_bytes():
    # the client sends one request and waits for the answer: no more bytes will come
    reader = FrameReader()
    assert reader.feed(frame(request(1), 50)) == [] and reader.waiting()
    assert received(reader.idle()) == [request(1)] and not reader.waiting()
    assert received(reader.feed(frame(request(2)))) == [request(2)]
    # a body still coming is not taken at a pause
    data = frame(request(3))
    assert reader.feed(data[:-3]) == [] and reader.idle() == []
    assert received(reader.feed(data[-3:])) == [request(3)]


def test_a_big_body_in_small_chunks_is_read_in_linear_time():
    text = "sphere { <1,2,3>, 1 pigment { rgb 1 } }\n" * 50_000  # 2 MB, braces everywhere
    data = frame(request(1, text))
    reader, events = FrameReader(), []
    start = time.perf_counter()
    for i in range(0, len(data), 4096):
        events += reader.feed(data[i : i + 4096])
    assert received(events) == [request(1, text)]
    assert time.perf_counter() - start < 2.0  # about 0.05 s; 10 s once for 20 MB


def test_a_huge_length_is_refused_without_reading_the_body_into_memory():
    reader = FrameReader()
    events = reader.feed(b"Content-Length: 99999999999\r\n\r\n")
    assert [type(e) for e in events] == [Unreadable] and "99999999999" in events[0].reason
    # the length was a lie: the next frame inside the "body" is read
    assert received(reader.feed(frame(request(1)))) == [request(1)]
    # an honest body over the limit is skipped, chunk by chunk, and the next frame read
    reader = FrameReader(max_body=1000)
    events = reader.feed(b"Content-Length: 5000\r\n\r\n")
    for _ in range(5):
        events += reader.feed(b"a" * 1000)
        assert reader.held <= 1000
    events += reader.feed(frame(request(2)))
    assert received(events) == [request(2)] and not reader.pending()


def test_a_body_may_mention_content_length():
    value = request(1, "Content-Length: 5\\r\\n and content-length")
    assert received(read(frame(value) + frame(request(2)))) == [value, request(2)]


def test_json_nested_past_pythons_frames_is_a_parse_error():
    deep = b"[" * 100_000 + b"]" * 100_000
    events = read(frame(deep) + frame(request(1)))
    assert [type(e) for e in events] == [Unreadable, Received]


def test_a_message_cut_off_by_the_end_of_the_stream_is_pending():
    reader = FrameReader()
    data = frame(request(1))
    assert reader.feed(data[:-5]) == [] and reader.pending()
    assert not FrameReader().pending()


@settings(max_examples=200, deadline=None)
@given(
    bad=st.sampled_from(sorted(BAD)),
    texts=st.lists(st.text(max_size=30), min_size=1, max_size=4),
    cuts=st.lists(st.integers(0, 2000), max_size=12),
)
def test_any_chunking_reads_the_same_frames(bad, texts, cuts):
    good = [request(i, t) for i, t in enumerate(texts)]
    data = BAD[bad][0] + b"".join(frame(g) for g in good)
    assert received(read(data, cuts))[-len(good) :] == good


@pytest.mark.parametrize(
    "value, ok",
    [
        ({"jsonrpc": "2.0", "id": 1, "method": "m"}, True),
        ({"jsonrpc": "2.0", "method": "m", "params": []}, True),
        ({"jsonrpc": "2.0", "id": 1, "result": None}, True),
        ([1, 2], False),
        ("text", False),
        ({"id": 1, "method": "m"}, False),
        ({"jsonrpc": "2.0", "id": 1}, False),
        ({"jsonrpc": "2.0", "id": [1], "method": "m"}, False),
        ({"jsonrpc": "2.0", "id": True, "method": "m"}, False),
        ({"jsonrpc": "2.0", "id": 1, "method": 5}, False),
        ({"jsonrpc": "2.0", "id": 1, "method": "m", "params": 3}, False),
    ],
)
def test_what_is_a_json_rpc_message(value, ok):
    assert (invalid_request(value) is None) == ok


def test_an_error_answers_the_id_when_it_is_one():
    assert request_id({"id": 4}) == 4 and request_id({"id": [4]}) is None
    assert request_id([1]) is None


@settings(max_examples=300, deadline=None)
@given(
    garbage=st.binary(min_size=1, max_size=300).filter(
        lambda b: b"content-length" not in b.lower()
    ),
    cuts=st.lists(st.integers(0, 600), max_size=8),
)
def test_after_any_bytes_that_hold_no_header_the_next_frames_are_read(garbage, cuts):
    good = [request(1), request(2)]
    events = read(garbage + frame(good[0]) + frame(good[1]), cuts)
    assert received(events)[-2:] == good
    assert len([e for e in events if isinstance(e, Unreadable)]) <= 1
