"""The language server analyses off the request thread (lang/lsp_analysis.py), end to end over
stdio with pytest-lsp's client: a slow document does not hold hover or completion, a newer
edit cancels the analysis of the older text (its diagnostics are never published), and
`$/cancelRequest` is honoured. Before, the analysis ran on the thread that reads requests:
every request waited for it (a 2 MB document 29.6 s, a long `#while` 22 s)."""

from __future__ import annotations

import asyncio
import os
import sys
import time
from pathlib import Path
from typing import Any

import pytest
import pytest_lsp
from lsprotocol import types as T
from pygls.exceptions import JsonRpcException
from pytest_lsp import ClientServerConfig, LanguageClient, client_capabilities, make_test_lsp_client

from lang.lsp_analysis import ANSWER_WAIT

ROOT = Path(__file__).resolve().parent.parent
REQUEST_CANCELLED = -32800  # LSP's RequestCancelled

# About 1 ms a pass (300 sines), 20,000 passes: some 20 s of evaluation alone, far inside the
# editor's step budget (3 steps a pass), every step a point where a cancel is seen.
_SINES = " + ".join(f"sin({i} * I)" for i in range(300))
HEAVY = f"""#declare Radius = 1;
#declare I = 0;
#while (I < 20000)
  #declare X = {_SINES};
  #declare I = I + 1;
#end
sphere {{ 0, Radius }}
"""
HEAVY_ALONE = 15.0  # seconds the heavy analysis takes at the least (measured: 19 s)
LIGHT = "#declare Size = 2.5;\nsphere { 0, Size }\n"


def _recording_client() -> LanguageClient:
    """pytest-lsp's client, keeping every publishDiagnostics in the order it came, with the
    time it came (the client's own record keeps only the last per document)."""
    client = make_test_lsp_client()
    published: list[tuple[float, T.PublishDiagnosticsParams]] = []
    handle = client.protocol.handle_message

    def record(message: Any) -> None:
        if getattr(message, "method", None) == T.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS:
            published.append((time.monotonic(), message.params))
        handle(message)

    client.protocol.handle_message = record  # type: ignore[method-assign]
    client.published = published  # type: ignore[attr-defined]
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


def _open(client: LanguageClient, path: Path, text: str) -> str:
    uri = path.as_uri()
    client.text_document_did_open(
        T.DidOpenTextDocumentParams(
            text_document=T.TextDocumentItem(uri=uri, language_id="pov", version=1, text=text)
        )
    )
    return uri


def _change(client: LanguageClient, uri: str, version: int, text: str) -> None:
    client.text_document_did_change(
        T.DidChangeTextDocumentParams(
            text_document=T.VersionedTextDocumentIdentifier(uri=uri, version=version),
            content_changes=[T.TextDocumentContentChangeWholeDocument(text=text)],
        )
    )


def _published(client: LanguageClient, uri: str) -> list[tuple[float, T.PublishDiagnosticsParams]]:
    return [(t, p) for t, p in client.published if p.uri == uri]  # type: ignore[attr-defined]


async def _until_published(client: LanguageClient, uri: str, version: int, timeout: float) -> float:
    """When the diagnostics of `version` of `uri` came (waiting at most `timeout`)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        for t, p in _published(client, uri):
            if p.version == version:
                return t
        await asyncio.sleep(0.02)
    raise AssertionError(f"no diagnostics for version {version} of {uri} in {timeout} s")


def _hover_params(uri: str, line: int, character: int) -> T.HoverParams:
    return T.HoverParams(
        text_document=T.TextDocumentIdentifier(uri=uri),
        position=T.Position(line=line, character=character),
    )


async def test_hover_and_completion_are_answered_while_a_heavy_document_is_analysed(
    client: LanguageClient, tmp_path
):
    heavy = _open(client, tmp_path / "heavy.pov", HEAVY)
    start = time.monotonic()
    light = _open(client, tmp_path / "light.pov", LIGHT)

    # another document: analysed beside the heavy one, its hover shows the analysed value
    await _until_published(client, light, 1, timeout=HEAVY_ALONE / 2)
    hov = await client.text_document_hover_async(_hover_params(light, 1, 13))
    assert hov is not None and "value: `2.5`" in hov.contents.value, hov
    assert time.monotonic() - start < HEAVY_ALONE / 2

    # the heavy document itself: answered from its parse, after at most ANSWER_WAIT, while
    # its evaluation goes on (nothing published for it yet)
    asked = time.monotonic()
    hov = await client.text_document_hover_async(_hover_params(heavy, 6, 13))
    assert hov is not None and "#declare Radius = 1;" in hov.contents.value, hov
    assert "value:" not in hov.contents.value  # no evaluation has ended to give one
    items = await client.text_document_completion_async(
        T.CompletionParams(
            text_document=T.TextDocumentIdentifier(uri=heavy),
            position=T.Position(line=6, character=0),
        )
    )
    assert items is not None and {"Radius", "I", "X"} <= {i.label for i in items.items}
    assert time.monotonic() - asked < 2 * ANSWER_WAIT + 2.0
    assert not _published(client, heavy)
    assert time.monotonic() - start < HEAVY_ALONE

    # closing it cancels its analysis: only the empty list that closing sends comes after
    client.text_document_did_close(
        T.DidCloseTextDocumentParams(text_document=T.TextDocumentIdentifier(uri=heavy))
    )
    await asyncio.sleep(0.5)
    assert [list(p.diagnostics) for _, p in _published(client, heavy)] == [[]]


async def test_a_newer_edit_cancels_the_analysis_of_the_older_text(
    client: LanguageClient, tmp_path
):
    """Version 1 (the heavy text, which would end with an #error) is being analysed when
    version 2 comes: version 2's diagnostics come long before version 1's analysis could have
    ended (one analysis of a document runs at a time, so version 1's was stopped), and no
    diagnostics of version 1 are ever published, before or after."""
    uri = _open(client, tmp_path / "edited.pov", HEAVY + '#error "version one"\n')
    await asyncio.sleep(0.5)  # its analysis is under way
    changed = time.monotonic()
    _change(client, uri, 2, LIGHT + '#warning "version two"\n')
    came = await _until_published(client, uri, 2, timeout=HEAVY_ALONE / 2)
    assert came - changed < HEAVY_ALONE / 2
    messages = [d.message for d in _published(client, uri)[-1][1].diagnostics]
    assert any("version two" in m for m in messages), messages

    # a burst of edits while version 3 (heavy again) is analysed: only the last is published
    _change(client, uri, 3, HEAVY + '#error "version three"\n')
    await asyncio.sleep(0.3)
    for version in range(4, 9):
        _change(client, uri, version, LIGHT + f'#warning "version {version}"\n')
        await asyncio.sleep(0.01)
    await _until_published(client, uri, 8, timeout=HEAVY_ALONE / 2)
    await asyncio.sleep(1.0)  # anything stale would come now
    versions = [p.version for _, p in _published(client, uri)]
    assert versions[0] == 2 and versions[-1] == 8, versions
    assert versions == sorted(versions) and not {1, 3} & set(versions), versions
    texts = [d.message for _, p in _published(client, uri) for d in p.diagnostics]
    assert not [m for m in texts if "version one" in m or "version three" in m]


async def test_cancel_request_is_honoured(client: LanguageClient, tmp_path):
    """A hover on a document whose analysis is running waits for it (ANSWER_WAIT at most);
    `$/cancelRequest` in that time ends the request with RequestCancelled, and the server
    answers the next request."""
    heavy = _open(client, tmp_path / "heavy.pov", HEAVY)
    await asyncio.sleep(0.3)
    reply = asyncio.ensure_future(
        client.protocol.send_request_async(
            T.TEXT_DOCUMENT_HOVER, _hover_params(heavy, 6, 13), msg_id="hover-to-cancel"
        )
    )
    await asyncio.sleep(0.05)  # pytest-lsp's send_request_async sends when first awaited
    client.protocol.notify(T.CANCEL_REQUEST, T.CancelParams(id="hover-to-cancel"))
    with pytest.raises(JsonRpcException) as caught:
        await asyncio.wait_for(reply, timeout=ANSWER_WAIT + 5.0)
    assert caught.value.code == REQUEST_CANCELLED
    symbols = await client.text_document_document_symbol_async(
        T.DocumentSymbolParams(text_document=T.TextDocumentIdentifier(uri=heavy))
    )
    assert symbols and "Radius" in [s.name for s in symbols]
