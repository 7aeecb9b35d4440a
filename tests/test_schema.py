"""The schema is the language's one list of words (lang/schema.py): the grammar reserves
exactly its words, and every block (the data shapes too) is described there."""

from __future__ import annotations

from lang import grammar, keywords, schema
from lang.eval import data_shapes

_VALUE_CLASSES = {"CONST", "FUNC", "COLOR_TYPE", "COLOR_WORD", "COMPONENT"}


def _lexed(words) -> dict[str, str]:
    """Each word's token type, from the grammar's own lexer."""
    toks = grammar.get_parser().lex(" ".join(sorted(words)))
    return {str(t): t.type for t in toks}


def test_the_grammar_reserves_exactly_the_schemas_words():
    """What the lexer takes as a keyword (not a name, not a value word) is what the schema
    lists, and the other way round; the schema's soft words stay names."""
    value_words = (
        keywords.CONSTANTS
        | keywords.FUNCTIONS
        | keywords.COLOR_TYPES
        | keywords.COLOR_WORDS
        | keywords.COMPONENTS
    )
    grammar_keywords = {
        w for w, kind in grammar.WORD_TYPES.items() if kind not in _VALUE_CLASSES
    } - {"deprecated", *grammar.OLD_DIRECTIVES}
    assert grammar_keywords == schema.RESERVED_WORDS - value_words
    lexed = _lexed(schema.RESERVED_WORDS | schema.SOFT_WORDS)
    assert {w for w, t in lexed.items() if t == "IDENT"} == schema.SOFT_WORDS
    assert {w for w in schema.RESERVED_WORDS if lexed[w] == "IDENT"} == set()


def test_the_words_the_schema_describes_are_reserved():
    """`pavement` (a pattern) and `iff` (an image format) are items of the schema, so they
    are keywords, as in POV-Ray 3.7, not names."""
    assert {"pavement", "iff"} <= keywords.ITEM_WORDS
    assert _lexed(["pavement", "iff"]) == {"pavement": "KEYWORD", "iff": "KEYWORD"}


def test_every_data_shape_has_a_spec():
    assert schema.DATA_SHAPES == data_shapes.SHAPES | {"isosurface"}
    for name in schema.DATA_SHAPES:
        spec = schema.spec(name)
        assert spec is not None and spec.free_form and spec.doc, name
        assert spec.produces == "object"
        assert all(item.doc for item in spec.items.values()), name
    lathe = schema.BLOCKS["lathe"]
    assert {"linear_spline", "quadratic_spline", "cubic_spline", "bezier_spline", "sturm"} <= set(
        lathe.items
    )
    assert {"threshold", "max_gradient", "contained_by"} <= set(schema.BLOCKS["isosurface"].items)
    assert not any(b.free_form for n, b in schema.BLOCKS.items() if n not in schema.DATA_SHAPES)


def test_items_is_the_public_name_of_the_item_parser():
    got = schema.items(["open | Leave the end caps off."], ["radius float | A radius."])
    assert got["radius"] == schema.Item("radius", ("float",), "A radius.")
    assert got["open"].signature == "open"
