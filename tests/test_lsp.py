"""The language server end to end: a real client over stdio (pytest-lsp)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest_lsp
from lsprotocol import types as T
from pytest_lsp import ClientServerConfig, LanguageClient, client_capabilities

ROOT = Path(__file__).resolve().parent.parent

BROKEN = """#declare Radius = 1;
#declare Gold = rgb <1, 0.8, 0.2>;
#macro Ball(P)
  sphere { P, Radius pigment { Gold } }
#end
sphere { <0,0,0>, Radius
  pigment { Gold }
}
}
Ball(<1,0,0>)
"""


@pytest_lsp.fixture(
    config=ClientServerConfig(
        server_command=[sys.executable, "-m", "lang.lsp"],
        server_env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
)
async def client(lsp_client: LanguageClient):
    await lsp_client.initialize_session(
        T.InitializeParams(
            capabilities=client_capabilities("visual-studio-code"),
            root_uri=ROOT.as_uri(),
        )
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


async def test_diagnostics_on_open_point_at_the_stray_brace(client: LanguageClient, tmp_path):
    uri = _open(client, tmp_path / "broken.pov", BROKEN)
    await client.wait_for_notification(T.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    diags = client.diagnostics[uri]
    errors = [d for d in diags if d.severity == T.DiagnosticSeverity.Error]
    assert errors, diags
    stray = [d for d in errors if d.range.start.line == 8]
    assert stray and stray[0].range.start.character == 0
    assert "unmatched" in stray[0].message


async def test_a_macro_body_error_lists_its_calls_as_related_information(
    client: LanguageClient, tmp_path
):
    text = "#macro M(A)\n  sphere { 0, A pigment { rgb foo } }\n#end\n\n  M(1)\n"
    path = tmp_path / "macro.pov"
    uri = _open(client, path, text)
    await client.wait_for_notification(T.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    (error,) = [d for d in client.diagnostics[uri] if d.severity == T.DiagnosticSeverity.Error]
    assert (error.range.start.line, error.range.start.character) == (1, 30)
    (call,) = error.related_information or []
    assert call.location.uri == path.resolve().as_uri()
    assert (call.location.range.start.line, call.location.range.start.character) == (4, 2)
    assert call.message == "in macro `M` called here"


async def test_diagnostics_follow_changes(client: LanguageClient, tmp_path):
    uri = _open(client, tmp_path / "a.pov", BROKEN)
    await client.wait_for_notification(T.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    fixed = BROKEN.replace("}\n}\nBall", "}\nBall")
    client.text_document_did_change(
        T.DidChangeTextDocumentParams(
            text_document=T.VersionedTextDocumentIdentifier(uri=uri, version=2),
            content_changes=[T.TextDocumentContentChangeWholeDocument(text=fixed)],
        )
    )
    await client.wait_for_notification(T.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    errors = [d for d in client.diagnostics[uri] if d.severity == T.DiagnosticSeverity.Error]
    assert not [d for d in errors if "unmatched" in d.message]


async def test_completion_hover_definition_symbols_folding_formatting(
    client: LanguageClient, tmp_path
):
    text = BROKEN.replace("}\n}\nBall", "}\nBall")
    uri = _open(client, tmp_path / "b.pov", text)
    doc = T.TextDocumentIdentifier(uri=uri)

    # completion inside `pigment {` on line 7 offers declared names and keywords
    result = await client.text_document_completion_async(
        T.CompletionParams(text_document=doc, position=T.Position(line=6, character=12))
    )
    labels = {i.label for i in result.items}
    assert {"Gold", "Radius", "Ball"} <= labels
    assert "checker" in labels

    # hover on `Radius` in line 6 shows its declaration, its value (from the analysis made on
    # didOpen, which the server finished before it read the requests) and where it was declared
    hov = await client.text_document_hover_async(
        T.HoverParams(text_document=doc, position=T.Position(line=5, character=20))
    )
    assert hov is not None
    assert "#declare Radius = 1;" in hov.contents.value
    assert "value: `1`" in hov.contents.value and "declared at b.pov:1:10" in hov.contents.value
    hov = await client.text_document_hover_async(
        T.HoverParams(text_document=doc, position=T.Position(line=6, character=13))
    )
    assert "value: `rgb <1, 0.8, 0.2>`" in hov.contents.value, hov.contents.value

    # go to definition of `Gold` used on line 7
    locs = await client.text_document_definition_async(
        T.DefinitionParams(text_document=doc, position=T.Position(line=6, character=13))
    )
    assert locs and locs[0].range.start.line == 1
    # … and of the macro `Ball` called on line 9
    locs = await client.text_document_definition_async(
        T.DefinitionParams(text_document=doc, position=T.Position(line=8, character=1))
    )
    assert locs and locs[0].uri == uri and locs[0].range.start.line == 2

    symbols = await client.text_document_document_symbol_async(
        T.DocumentSymbolParams(text_document=doc)
    )
    names = [s.name for s in symbols]
    assert names[:3] == ["Radius", "Gold", "Ball"] and "sphere" in names

    folds = await client.text_document_folding_range_async(T.FoldingRangeParams(text_document=doc))
    assert any(f.start_line == 2 and f.end_line == 4 for f in folds)  # the macro

    edits = await client.text_document_formatting_async(
        T.DocumentFormattingParams(
            text_document=doc, options=T.FormattingOptions(tab_size=2, insert_spaces=True)
        )
    )
    assert edits and "  pigment { Gold }" in edits[0].new_text


async def test_definition_of_include_opens_the_stdlib_file(client: LanguageClient, tmp_path):
    uri = _open(client, tmp_path / "c.pov", '#include "colors.inc"\nsphere { 0, 1 }\n')
    locs = await client.text_document_definition_async(
        T.DefinitionParams(
            text_document=T.TextDocumentIdentifier(uri=uri),
            position=T.Position(line=0, character=12),
        )
    )
    assert locs and locs[0].uri.endswith("stdlib/colors.inc")


async def test_completion_is_driven_by_the_schema_and_hover_shows_docs(
    client: LanguageClient, tmp_path
):
    text = "sphere { 0, 1\n  finish { phong 1  }\n}\n"
    doc = T.TextDocumentIdentifier(uri=_open(client, tmp_path / "d.pov", text))
    keywords = await _keywords_at(client, doc, 1, 19)
    assert {"phong", "specular", "reflection", "metallic"} <= keywords
    assert "sphere" not in keywords and "look_at" not in keywords
    assert "phong <float>" in await _hover_at(client, doc, 1, 13)


async def test_hover_describes_a_keyword_as_the_block_it_is_in(client: LanguageClient, tmp_path):
    # `emission` is an item of finish, sky_sphere and media: each says its own
    text = "sphere { 0, 1 finish { emission 1 } }\nsky_sphere { emission 2 }\n"
    doc = T.TextDocumentIdentifier(uri=_open(client, tmp_path / "e.pov", text))
    in_finish = await _hover_at(client, doc, 0, 25)
    assert "Light the surface emits" in in_finish and "Sky" not in in_finish
    assert "Sky brightness" in await _hover_at(client, doc, 1, 15)


async def _keywords_at(
    client: LanguageClient, doc: T.TextDocumentIdentifier, line: int, character: int
) -> set[str]:
    """The keywords completion offers at a (0-based) position."""
    result = await client.text_document_completion_async(
        T.CompletionParams(text_document=doc, position=T.Position(line=line, character=character))
    )
    assert result is not None
    return {i.label for i in result.items if i.kind == T.CompletionItemKind.Keyword}


async def _hover_at(
    client: LanguageClient, doc: T.TextDocumentIdentifier, line: int, character: int
) -> str:
    """What hover shows at a (0-based) position."""
    hov = await client.text_document_hover_async(
        T.HoverParams(text_document=doc, position=T.Position(line=line, character=character))
    )
    assert hov is not None
    return hov.contents.value


async def test_completion_and_hover_inside_a_data_shape_come_from_its_schema(
    client: LanguageClient, tmp_path
):
    """`lathe`, `blob`, `isosurface` … read free-form data, but the schema still describes
    them: inside `lathe {` completion offers lathe's items, and hover shows their docs."""
    text = "lathe {\n  bezier_spline 4, <0, 0>, <1, 1>, <1, 2>, <0, 3>\n  \n}\n"
    doc = T.TextDocumentIdentifier(uri=_open(client, tmp_path / "l.pov", text))
    keywords = await _keywords_at(client, doc, 2, 2)
    assert {"linear_spline", "quadratic_spline", "cubic_spline", "bezier_spline"} <= keywords
    assert {"sturm", "translate", "pigment", "texture"} <= keywords
    assert "look_at" not in keywords and "phong" not in keywords and "lathe" not in keywords
    assert "Cubic Bézier segments of four points each" in await _hover_at(client, doc, 1, 5)
    assert "surface of revolution" in await _hover_at(client, doc, 0, 2)


def _scene(n: int) -> str:
    out = ['#include "colors.inc"', "camera { location <0, 2, -9> look_at 0 }"]
    for i in range(n):
        out.append(f"#declare P{i} = <{i % 5}, 0, {i % 3}>;")
        out.append(f"#if (P{i}.x > 1)\n  sphere {{ P{i}, 0.3 pigment {{ Red }} }}\n#end")
    return "\n".join(out) + "\n"


async def test_diagnostics_after_edits_equal_those_of_a_fresh_open(
    client: LanguageClient, tmp_path
):
    """The server re-parses only what each edit touched; what it reports must not depend on
    that: after a series of edits, the same diagnostics as the final text opened afresh."""
    text = _scene(200)
    uri = _open(client, tmp_path / "edited.pov", text)
    await client.wait_for_notification(T.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    mid = text.index("#declare P100 ")
    steps = [
        text[:mid] + "#declare W = <1, 2\n" + text[mid:],  # an unfinished vector
        "// a comment line\n\n" + text[:mid] + "sphere { Missing, 1 }\n" + text[mid:],
        "// a comment line\n\n" + text.replace("P152, 0.3", "P152, 0.3 angle 2"),
        text[:mid] + "sphere {\n" + text[mid:],  # a block left open: the rest is inside it
    ]
    for version, new in enumerate(steps, start=2):
        client.text_document_did_change(
            T.DidChangeTextDocumentParams(
                text_document=T.VersionedTextDocumentIdentifier(uri=uri, version=version),
                content_changes=[T.TextDocumentContentChangeWholeDocument(text=new)],
            )
        )
        await client.wait_for_notification(T.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
        edited = client.diagnostics[uri]
        fresh_uri = _open(client, tmp_path / f"fresh{version}.pov", new)
        await client.wait_for_notification(T.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
        fresh = client.diagnostics[fresh_uri]
        assert edited, new[:40]  # every step has a mistake in it
        key = [(d.range, d.code, d.message) for d in edited]
        assert key == [(d.range, d.code, d.message) for d in fresh]


async def test_completion_and_hover_know_the_included_and_built_in_names(
    client: LanguageClient, tmp_path
):
    (tmp_path / "mine.inc").write_text("#declare Mine_Size = 2.5;\n")
    text = '#include "colors.inc"\n#include "mine.inc"\nsphere { 0, 1 pigment { Red } }\n\n'
    uri = _open(client, tmp_path / "e.pov", text)
    await client.wait_for_notification(T.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    doc = T.TextDocumentIdentifier(uri=uri)
    result = await client.text_document_completion_async(
        T.CompletionParams(text_document=doc, position=T.Position(line=3, character=0))
    )
    labels = {i.label: i for i in result.items}
    assert {"Red", "MediumAquamarine", "Mine_Size"} <= set(labels)  # from the includes
    assert labels["Mine_Size"].detail == "mine.inc:1"
    assert {"sqrt", "vlength", "pi", "clock", "rgb"} <= set(labels)  # built-in names
    assert labels["pi"].kind == T.CompletionItemKind.Constant

    hov = await client.text_document_hover_async(
        T.HoverParams(text_document=doc, position=T.Position(line=2, character=25))
    )
    value = hov.contents.value
    assert "#declare Red" in value and "value: `rgb <1, 0, 0>`" in value
    assert "declared at colors.inc:" in value
    locs = await client.text_document_definition_async(
        T.DefinitionParams(text_document=doc, position=T.Position(line=2, character=25))
    )
    colors = (ROOT / "stdlib" / "colors.inc").read_text().splitlines()
    red_line = next(i for i, line in enumerate(colors) if line.startswith("#declare Red "))
    assert locs and locs[0].uri.endswith("stdlib/colors.inc")
    assert locs[0].range.start.line == red_line

    # `#include "` offers the include files; `#` offers the directives
    client.text_document_did_change(
        T.DidChangeTextDocumentParams(
            text_document=T.VersionedTextDocumentIdentifier(uri=uri, version=2),
            content_changes=[T.TextDocumentContentChangeWholeDocument(text=text + '#include "')],
        )
    )
    result = await client.text_document_completion_async(
        T.CompletionParams(text_document=doc, position=T.Position(line=4, character=10))
    )
    files = {i.label for i in result.items}
    assert {"colors.inc", "metals.inc", "mine.inc"} <= files and "Red" not in files
    client.text_document_did_change(
        T.DidChangeTextDocumentParams(
            text_document=T.VersionedTextDocumentIdentifier(uri=uri, version=3),
            content_changes=[T.TextDocumentContentChangeWholeDocument(text=text + "#dec")],
        )
    )
    result = await client.text_document_completion_async(
        T.CompletionParams(text_document=doc, position=T.Position(line=4, character=4))
    )
    assert {"declare", "macro", "include"} <= {i.label for i in result.items}
    assert "sphere" not in {i.label for i in result.items}


CUT = """#declare K = 1;
#declare A = sphere { 0, 1 }
#switch (K) #case (0) object { A #break #case (1) object { A scale 2 #break #end
  translate x
}
#if (K) merge { #else union { #end
  sphere { 0, 1 } sphere { x, 1 }
}
#declare Later = 2;
"""


async def test_directives_cut_across_blocks_give_no_false_error_and_keep_the_tools(
    client: LanguageClient, tmp_path
):
    """POV-Ray reads these as its token stream: no syntax error; the declarations around
    them keep their symbols and hover."""
    uri = _open(client, tmp_path / "cut.pov", CUT)
    await client.wait_for_notification(T.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    errors = [d for d in client.diagnostics[uri] if d.severity == T.DiagnosticSeverity.Error]
    assert not errors, errors
    doc = T.TextDocumentIdentifier(uri=uri)
    symbols = await client.text_document_document_symbol_async(
        T.DocumentSymbolParams(text_document=doc)
    )
    names = [s.name for s in symbols]
    assert {"K", "A", "Later"} <= set(names), names
    hov = await client.text_document_hover_async(
        T.HoverParams(text_document=doc, position=T.Position(line=8, character=10))
    )
    assert hov is not None and "value: `2`" in hov.contents.value
