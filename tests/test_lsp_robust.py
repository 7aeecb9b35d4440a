"""The language server under bad framing and bad messages, end to end over stdio (pytest-lsp;
the bad bytes go through its client's writer). Each case: no crash, no hang, the JSON-RPC
error the protocol names, and the next valid request answered. Before, a Content-Length 10
bytes short or 50 long, or a header without its blank line, left the server deaf for good;
`Content-Length: 99999999999` killed it (MemoryError); a negative position got no reply.

The lifecycle (requests after shutdown, the exit status, stdin closed in the middle of a
message) is tested on a subprocess spoken to in raw bytes (tests/lsp_raw.py): pytest-lsp's
fixture shuts the server down itself and cannot close its stdin half-way."""

from __future__ import annotations

import asyncio
import json
import os
import sys
from pathlib import Path
from typing import Any

import pytest
import pytest_lsp
from lsp_raw import RawServer, frame
from lsprotocol import types as T
from pygls.exceptions import JsonRpcException
from pytest_lsp import ClientServerConfig, LanguageClient, client_capabilities, make_test_lsp_client

ROOT = Path(__file__).resolve().parent.parent
TEXT = "#declare R = 1;\nsphere { 0, R }\n"
PARSE_ERROR, INVALID_REQUEST, METHOD_NOT_FOUND, INVALID_PARAMS = -32700, -32600, -32601, -32602


def _recording_client() -> LanguageClient:
    """pytest-lsp's client, keeping every response it gets that answers no request of its
    own: those have id null (the errors for bad frames) or a number (the raw requests here;
    the client's own ids are strings)."""
    client = make_test_lsp_client()
    seen: list[Any] = []
    handle = client.protocol.handle_message

    def record(message: Any) -> None:
        msg_id = getattr(message, "id", "")
        if not hasattr(message, "method") and (msg_id is None or isinstance(msg_id, int)):
            seen.append(message)
        handle(message)

    client.protocol.handle_message = record  # type: ignore[method-assign]
    client.seen = seen  # type: ignore[attr-defined]
    return client


@pytest_lsp.fixture(
    config=ClientServerConfig(
        server_command=[sys.executable, "-m", "lang.lsp"],
        server_env={**os.environ, "PYTHONPATH": str(ROOT)},
        client_factory=_recording_client,
    )
)
async def client(lsp_client: LanguageClient):
    await lsp_client.initialize_session(
        T.InitializeParams(capabilities=client_capabilities("visual-studio-code"))
    )
    yield
    await lsp_client.shutdown_session()


async def _open(client: LanguageClient, tmp_path: Path) -> str:
    uri = (tmp_path / "s.pov").as_uri()
    client.text_document_did_open(
        T.DidOpenTextDocumentParams(
            text_document=T.TextDocumentItem(uri=uri, language_id="pov", version=1, text=TEXT)
        )
    )
    await asyncio.wait_for(client.wait_for_notification(T.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS), 30)
    return uri


async def _still_serving(client: LanguageClient, uri: str) -> None:
    hover = await asyncio.wait_for(
        client.text_document_hover_async(
            T.HoverParams(
                text_document=T.TextDocumentIdentifier(uri=uri),
                position=T.Position(line=1, character=2),
            )
        ),
        30,
    )
    assert hover is not None and "sphere" in hover.contents.value  # type: ignore[union-attr]


def _write(client: LanguageClient, data: bytes) -> None:
    writer = client.protocol.writer
    assert writer is not None
    writer.write(data)  # type: ignore[union-attr]


def _errors(client: LanguageClient) -> list[tuple[Any, int]]:
    return [(m.id, m.error.code) for m in client.seen if hasattr(m, "error")]  # type: ignore[attr-defined]


def _hover_request(msg_id: int, uri: str, line: Any = 1, character: Any = 2) -> dict[str, Any]:
    return {
        "jsonrpc": "2.0",
        "id": msg_id,
        "method": "textDocument/hover",
        "params": {
            "textDocument": {"uri": uri},
            "position": {"line": line, "character": character},
        },
    }


# bad bytes on the stream, and the errors they are answered with (id, code)
def _bad_frames(uri: str) -> dict[str, tuple[bytes, list[tuple[Any, int]]]]:
    req = _hover_request(900, uri)
    body = json.dumps(req).encode()
    return {
        "Content-Length 10 bytes short": (frame(req, -10), [(None, PARSE_ERROR)]),
        "Content-Length 50 bytes long": (frame(req, 50), []),  # read, and answered
        "no Content-Length": (b"Content-Type: x\r\n\r\n" + body, [(None, PARSE_ERROR)]),
        "a header without the blank line": (
            frame(req)[: -len(body) - 2] + body,
            [(None, PARSE_ERROR)],
        ),  # fmt: skip
        "a body that is not JSON": (frame(b"{not json"), [(None, PARSE_ERROR)]),
        "JSON nested 100,000 deep": (
            frame(b"[" * 100_000 + b"]" * 100_000),
            [(None, PARSE_ERROR)],
        ),  # fmt: skip
        "a body that is not UTF-8": (frame(b'\xff\xfe{"a": 1}'), [(None, PARSE_ERROR)]),
        "a huge Content-Length": (b"Content-Length: 99999999999\r\n\r\n", [(None, PARSE_ERROR)]),
        "JSON that is an array": (frame([1, 2]), [(None, INVALID_REQUEST)]),
        "JSON without jsonrpc": (frame({"id": 901, "method": "x"}), [(901, INVALID_REQUEST)]),
        "JSON without a method": (frame({"jsonrpc": "2.0", "id": 902}), [(902, INVALID_REQUEST)]),
        "an unknown method": (
            frame({"jsonrpc": "2.0", "id": 903, "method": "strala/none"}),
            [(903, METHOD_NOT_FOUND)],
        ),  # fmt: skip
        "an unknown notification": (frame({"jsonrpc": "2.0", "method": "strala/none"}), []),
        "params of the wrong types": (
            frame({**_hover_request(904, uri), "params": {"textDocument": 5, "position": "x"}}),
            [(904, INVALID_PARAMS)],
        ),
        "a negative position": (frame(_hover_request(905, uri, -1, -5)), [(905, INVALID_PARAMS)]),
        "a document never opened": (
            frame(_hover_request(906, (ROOT / "no such.pov").as_uri())),
            [(906, INVALID_PARAMS)],
        ),
    }


CASES = sorted(_bad_frames("file:///x"))


@pytest.mark.parametrize("case", CASES)
async def test_a_bad_frame_or_message_gets_its_error_and_the_server_goes_on(
    client: LanguageClient, tmp_path, case
):
    uri = await _open(client, tmp_path)
    data, expected = _bad_frames(uri)[case]
    _write(client, data)
    await _still_serving(client, uri)
    assert _errors(client) == expected
    if case == "Content-Length 50 bytes long":
        assert [m.id for m in client.seen] == [900]  # type: ignore[attr-defined]
    # nothing went to the user as a server error either
    assert not [m for m in client.messages if "Error in server" in m.message]


async def test_positions_out_of_the_document_are_answered(client: LanguageClient, tmp_path):
    uri = await _open(client, tmp_path)
    far = T.Position(line=1_000_000, character=1_000_000)
    doc = T.TextDocumentIdentifier(uri=uri)
    assert await client.text_document_hover_async(T.HoverParams(doc, far)) is None
    assert await client.text_document_definition_async(T.DefinitionParams(doc, far)) is None
    done = await client.text_document_completion_async(T.CompletionParams(doc, far))
    assert done is not None
    await _still_serving(client, uri)


async def test_a_change_to_a_document_never_opened_is_ignored(client: LanguageClient, tmp_path):
    uri = await _open(client, tmp_path)
    never = (tmp_path / "never.pov").as_uri()
    client.text_document_did_change(
        T.DidChangeTextDocumentParams(
            text_document=T.VersionedTextDocumentIdentifier(uri=never, version=2),
            content_changes=[T.TextDocumentContentChangeWholeDocument(text="sphere {")],
        )
    )
    await _still_serving(client, uri)
    await asyncio.sleep(0.3)  # a diagnostics run would have been at once
    assert never not in client.diagnostics
    assert not [m for m in client.messages if "Error in server" in m.message]


async def test_an_unknown_method_is_method_not_found(client: LanguageClient):
    with pytest.raises(JsonRpcException) as e:
        await asyncio.wait_for(client.protocol.send_request_async("strala/none", {}), 30)
    assert e.value.code == METHOD_NOT_FOUND


# ---------------------------------------------------------------- lifecycle, raw bytes
@pytest.fixture
def raw(tmp_path):
    server = RawServer()
    server.initialize(tmp_path)
    yield server
    server.kill()


def test_requests_after_shutdown_are_invalid_and_exit_is_clean(raw, tmp_path):
    uri = (tmp_path / "s.pov").as_uri()
    raw.notify("textDocument/didOpen", {"textDocument": {"uri": uri, "languageId": "pov",
                                                         "version": 1, "text": TEXT}})  # fmt: skip
    raw.send(_hover_request(1, uri))
    assert "result" in raw.answer(1)
    raw.request(2, "shutdown")
    assert raw.answer(2)["result"] is None
    raw.send(_hover_request(3, uri))
    assert raw.answer(3)["error"]["code"] == INVALID_REQUEST
    raw.send({"jsonrpc": "2.0", "method": "exit"})
    assert raw.wait() == 0
    assert "Traceback" not in raw.stderr


@pytest.mark.parametrize("shut_down", [True, False])
def test_stdin_closed_in_the_middle_of_a_message_ends_the_server(raw, shut_down):
    if shut_down:
        raw.request(2, "shutdown")
        raw.answer(2)
    raw.send(frame(_hover_request(5, "file:///x"))[:40])
    raw.close_stdin()
    assert raw.wait() == 0  # the end of input is a clean end (only `exit` says 1)
    assert "Traceback" not in raw.stderr
    assert "in the middle of a message" in raw.stderr


def test_a_request_before_initialize_is_refused():
    server = RawServer()
    try:
        server.send(_hover_request(1, "file:///x.pov"))
        assert server.answer(1)["error"]["code"] == -32002  # LSP's ServerNotInitialized
        server.notify("textDocument/didOpen", {"textDocument": {"uri": "file:///x.pov",
                      "languageId": "pov", "version": 1, "text": TEXT}})  # fmt: skip
        server.initialize(ROOT)
        server.send(_hover_request(2, "file:///x.pov"))  # the early didOpen was dropped
        assert server.answer(2)["error"]["code"] == INVALID_PARAMS
        assert server.proc.poll() is None
    finally:
        server.kill()


def test_exit_without_shutdown_is_status_1(raw):
    raw.send({"jsonrpc": "2.0", "method": "exit"})
    assert raw.wait() == 1


def test_a_length_too_long_is_answered_though_no_more_bytes_come(raw, tmp_path):
    uri = (tmp_path / "s.pov").as_uri()
    raw.notify("textDocument/didOpen", {"textDocument": {"uri": uri, "languageId": "pov",
                                                         "version": 1, "text": TEXT}})  # fmt: skip
    raw.send(frame(_hover_request(7, uri), 50))  # and nothing after it: the client waits
    assert "sphere" in raw.answer(7, timeout=10)["result"]["contents"]["value"]
