"""Template analysis and matching, without a space."""

from __future__ import annotations

import pytest

from tuplespace import ANY, Template, compile_template, match_fields


def test_any_is_a_singleton_with_a_readable_repr() -> None:
    assert type(ANY)() is ANY
    assert repr(ANY) == "ANY"


@pytest.mark.parametrize(
    ("template", "tup", "expected"),
    [
        (("a", 1), ("a", 1), True),
        (("a", 1), ("a", 2), False),
        (("a", 1), ("a", 1.0), True),  # == equality, like tuples
        (("a", [1, 2]), ("a", [1, 2]), True),  # unhashable fields
        (("a", {"k": 1}), ("a", {"k": 2}), False),
        (("a", ANY), ("a", object()), True),
        ((ANY, ANY), (1, None), True),
        ((str, int), ("a", 1), True),
        ((str, int), ("a", "1"), False),
        ((str, int), ("a", True), True),  # isinstance: bool is an int
        ((str, lambda v: v > 2), ("a", 3), True),
        ((str, lambda v: v > 2), ("a", 2), False),
        (("a",), ("a", 1), False),  # arity differs
        ((), (), True),
    ],
)
def test_match_fields(
    template: tuple[object, ...], tup: tuple[object, ...], expected: bool
) -> None:
    assert match_fields(template, tup) is expected


def test_a_type_is_a_formal_not_a_value() -> None:
    assert match_fields((int,), (3,))
    assert not match_fields((int,), (int,))


def test_analysis_tells_exact_and_keyed_templates() -> None:
    exact = compile_template(("lock", 1))
    assert (exact.exact, exact.keyed, exact.key) == (True, True, "lock")
    keyed = compile_template(("lock", ANY))
    assert (keyed.exact, keyed.keyed, keyed.key) == (False, True, "lock")
    unhashable = compile_template(([1], ANY))
    assert (unhashable.exact, unhashable.keyed) == (False, False)
    formal_first = compile_template((str, 1))
    assert (formal_first.exact, formal_first.keyed) == (False, False)
    assert isinstance(exact, Template)
    assert repr(keyed) == "Template(('lock', ANY))"


def test_analysis_is_memoised_for_formal_templates() -> None:
    assert compile_template(("memo", ANY)) is compile_template(("memo", ANY))


def test_templates_with_unhashable_fields_are_analysed_afresh() -> None:
    assert compile_template(([1], ANY)).matches(([1], 2))


@pytest.mark.source_only("an argument of the wrong type")
def test_a_non_tuple_template_is_a_type_error() -> None:
    with pytest.raises(TypeError, match=r"\['a', 1\]"):
        compile_template(["a", 1])  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="expected a tuple"):
        match_fields(("a",), ["a"])  # type: ignore[arg-type]


def test_a_raising_predicate_propagates() -> None:
    def boom(value: object) -> bool:
        raise ZeroDivisionError

    with pytest.raises(ZeroDivisionError):
        match_fields((boom,), (1,))


@pytest.mark.parametrize(
    "template",
    [
        ("lock", ANY, ANY),
        ("lock", 1, ANY),
        ("lock", [1], ANY),
        ("lock", int, ANY),
        ("lock", 1, lambda v: v > 2),
        ("lock", 1, 2),
    ],
)
def test_the_rest_of_a_keyed_template_matches_as_the_whole_does_in_its_bucket(
    template: tuple[object, ...],
) -> None:
    t = compile_template(template)
    assert t.keyed
    for tup in [
        ("lock", 1, 3),
        ("lock", 1.0, 2),
        ("lock", [1], 3),
        ("lock", "x", 0),
        ("lock", 2, 5),
    ]:
        assert t.rest(tup) == t.matches(tup), tup
