"""Templates and matching: pure functions, no locks, no clock.

A template is a tuple of the same arity as the tuples it matches. Each field is one of

- ``ANY``: matches every value;
- a type (``int``, ``str``, a class): matches instances of it (``isinstance``);
- a predicate, any other callable: matches when ``pred(value)`` is truthy;
- anything else: an exact value, compared the way tuples compare their items
  (identity first, then ``==``), so unhashable values such as lists and dicts work.

A template whose first field is an exact hashable value is *keyed*: the space looks it
up in the bucket of tuples sharing that first field instead of scanning every tuple of
that arity.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, ClassVar, Final, final

__all__ = ["ANY", "Template", "compile_template", "match_fields"]

Fields = tuple[Any, ...]

# Field kinds, kept as small ints: the matching loop compares them with ``is``.
_EXACT: Final = 0
_TYPE: Final = 1
_PREDICATE: Final = 2


@final
class _Any:
    """The wildcard: a template field that matches every value."""

    __slots__ = ()
    _instance: ClassVar[_Any | None] = None

    def __new__(cls) -> _Any:
        if cls._instance is None:
            cls._instance = super().__new__(cls)
        return cls._instance

    def __call__(self, value: object) -> bool:
        # Callable on purpose: "no field is callable" then tells an all-exact template
        # in one C-level pass (any(map(callable, t))), and ANY is also a valid
        # predicate that accepts everything.
        return True

    def __repr__(self) -> str:
        return "ANY"

    def __reduce__(self) -> str:
        return "ANY"


ANY: Final = _Any()
"""Template field that matches any value."""


@final
class Template:
    """A template analysed once, so that matching does no classification.

    Attributes:
        fields: the template as given.
        arity: how many fields a matching tuple has.
        exact: every field is an exact value, so ``tup == fields`` decides a match.
        keyed: the first field is an exact hashable value (see ``key``).
        key: the first field when ``keyed``, else ``None``.
        checks: ``(index, kind, value)`` for every field that is not ``ANY``.
    """

    __slots__ = ("arity", "checks", "exact", "fields", "key", "keyed", "rest")

    def __init__(self, fields: Fields) -> None:
        checks: list[tuple[int, int, Any]] = []
        for i, value in enumerate(fields):
            if value is ANY:
                continue
            if isinstance(value, type):
                checks.append((i, _TYPE, value))
            elif callable(value):
                checks.append((i, _PREDICATE, value))
            else:
                checks.append((i, _EXACT, value))
        self.fields: Fields = fields
        self.arity: int = len(fields)
        self.checks: tuple[tuple[int, int, Any], ...] = tuple(checks)
        self.exact: bool = len(checks) == len(fields) and all(
            kind == _EXACT for _, kind, _ in checks
        )
        keyed = bool(checks) and checks[0][0] == 0 and checks[0][1] == _EXACT
        if keyed:
            try:
                hash(fields[0])
            except TypeError:
                keyed = False
        self.keyed: bool = keyed
        self.key: Any = fields[0] if keyed else None
        #: For a keyed template, whether a tuple of its key's bucket matches: the first
        #: field needs no check there (the bucket holds the tuples whose first field
        #: equals the key), and the usual rest, one exact field or none, is one
        #: comparison.
        self.rest: Callable[[Fields], bool] = self.matches
        if keyed:
            rest = checks[1:]
            if not rest:
                self.rest = _always
            elif len(rest) == 1 and rest[0][1] == _EXACT:
                index, _, value = rest[0]
                self.rest = lambda tup: tup[index] is value or tup[index] == value
            else:
                # The same checks but the first: a template with ANY there.
                self.rest = Template((ANY, *fields[1:])).matches

    def matches(self, tup: Fields) -> bool:
        """Tell whether ``tup`` (already known to have this arity) matches.

        Raises:
            Exception: whatever a predicate field raises.
        """
        for i, kind, value in self.checks:
            field = tup[i]
            if kind == _EXACT:
                if not (field is value or field == value):
                    return False
            elif kind == _TYPE:
                if not isinstance(field, value):
                    return False
            elif not value(field):
                return False
        return True

    def __repr__(self) -> str:
        return f"Template({self.fields!r})"


def _always(tup: Fields) -> bool:
    return True


def match_fields(template: Fields, tup: Fields) -> bool:
    """Tell whether ``tup`` matches ``template``: the reference definition, unindexed.

    Raises:
        TypeError: ``template`` or ``tup`` is not a tuple.
    """
    if not isinstance(tup, tuple):
        raise TypeError(f"expected a tuple, got {tup!r}")
    t = compile_template(template)
    return len(tup) == t.arity and t.matches(tup)


# Analysed templates with formal fields, keyed by the template itself. Most programs use
# a handful of such templates, so hashing the template (cached for str, cheap for small
# tuples) beats re-classifying every field on every call. Equal templates share an entry; that is
# sound because an exact field is compared with ``==`` anyway. Bounded: a program that
# builds a fresh lambda per call would otherwise grow it forever.
_CACHE: dict[Fields, Template] = {}
_CACHE_MAX: Final = 4096


def compile_template(template: Fields) -> Template:
    """Analyse ``template`` (memoised for hashable templates).

    Raises:
        TypeError: ``template`` is not a tuple.
    """
    if type(template) is not tuple and not isinstance(template, tuple):
        raise TypeError(f"a template must be a tuple, got {template!r}")
    try:
        compiled = _CACHE.get(template)
    except TypeError:  # an unhashable field: analyse afresh
        return Template(template)
    if compiled is None:
        compiled = Template(template)
        if compiled.exact:
            # Usually unique (ids, counters): caching would only churn the cache.
            return compiled
        if len(_CACHE) >= _CACHE_MAX:
            _CACHE.clear()
        _CACHE[template] = compiled
    return compiled
