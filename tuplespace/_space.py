"""The tuplespace: a thread-safe, asyncio-aware Linda store.

Layout of the store. Every tuple gets a sequence number when written; FIFO order is
sequence order. Tuples are grouped by arity, and inside an arity

- ``all`` holds every tuple of that arity, oldest first, for templates whose first
  field is ``ANY``, a type or a predicate;
- ``by_first`` maps a hashable first field to the tuples starting with it, so a
  template with a concrete first field (the usual tag: ``("locked", agv, ANY)``) looks
  at those tuples only and never at unrelated ones;
- ``unkeyed`` holds the few tuples whose first field is unhashable (a list, a set);
  they can still equal a hashable template field (``{1} == frozenset({1})``), so keyed
  lookups consult them too, which costs nothing while there are none.

Each of these is a ``_Queue`` (a deque) of entries ``[tup, seq]`` shared between the
queues a tuple is in. Removing a tuple sets its entry's ``tup`` to ``None``: the dead
entry is popped at once when it is at the front (the usual FIFO case) and otherwise
skipped until the queue compacts, once dead entries outnumber live ones. Dicts, the
obvious alternative, keep insertion order too, but deleting from their front leaves
holes that every later iteration walks over, which turns a queue of 100k tuples
drained from the front into quadratic work.

Concurrency. One ``threading.Lock`` guards the store, the waiters and the observers.
Work that must not run under the lock (notify callbacks, waking a blocked thread or
task) is queued in ``_after`` while the lock is held and run by the same call once the
lock is released, so a callback may use the space freely. Blocked takers and readers,
threads and tasks alike, wait in one FIFO; a written tuple is offered to them in
arrival order before it is stored. Tasks are woken with ``call_soon_threadsafe`` (or
directly when the writer runs on the task's own loop thread).

Leases. Lease ends are kept in a heap. Every operation first drops tuples whose lease
ended by the clock, so an ended lease never matches even if nobody calls ``expire()``;
``next_expiry()`` and ``expire()`` let a simulated runtime fire expiry at exact
virtual times.
"""

from __future__ import annotations

import asyncio
import heapq
import itertools
import logging
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from types import TracebackType
from typing import TYPE_CHECKING, Any, Final

from mypy_extensions import mypyc_attr

from ._match import Template, compile_template

if TYPE_CHECKING:
    from ._watch import Watch

__all__ = ["KINDS", "NotifyHandle", "TupleSpace"]

Tup = tuple[Any, ...]
Callback = Callable[[str, Tup], object]

KINDS: Final = frozenset({"out", "in", "expire"})
"""Event kinds a ``notify`` observer can ask for."""

_log = logging.getLogger("tuplespace")


def _analyse(tmpl: Tup) -> Template | None:
    """``None`` for an all-exact template (the fast path), else its analysis.

    Raises:
        TypeError: ``tmpl`` is not a tuple.
    """
    if type(tmpl) is tuple and not any(map(callable, tmpl)):
        return None
    return compile_template(tmpl)


# Not a native class when compiled: a native class cannot extend deque.
@mypyc_attr(native_class=False)
class _Queue(deque[list[Any]]):
    """Entries oldest first; ``dead`` counts removed entries still inside."""

    dead = 0  # a class default: setting it in __init__ would double the creation cost


# An entry is a list ``[tup, seq, bucket]``: the tuple (``None`` once removed), its
# sequence number, and the ``by_first`` or ``unkeyed`` queue it also sits in (``None``
# for the empty tuple). A list indexed by literals, not an object with attributes,
# because one is built on every ``out`` and read on every match.


def _unlink(q: _Queue, entry: list[Any]) -> None:
    """Account for ``entry`` of ``q`` having died; keep the front of ``q`` live."""
    if q[-1] is entry:  # the newest: a tuple taken right after it was written
        q.pop()
    elif q[0] is entry:
        q.popleft()
        while q and q[0][0] is None:
            q.popleft()
            q.dead -= 1
    else:
        q.dead += 1
        if q.dead > 32 and 2 * q.dead > len(q):
            live = [e for e in q if e[0] is not None]
            q.clear()
            q.extend(live)
            q.dead = 0


class _Arity:
    """The tuples of one arity (see the module docstring)."""

    __slots__ = ("all", "by_first", "unkeyed")

    def __init__(self) -> None:
        self.all = _Queue()
        self.by_first: dict[Any, _Queue] = {}
        self.unkeyed = _Queue()


class _Waiter:
    """A blocked ``rd``/``in_`` (thread) or ``ard``/``ain`` (task)."""

    __slots__ = ("done", "result", "take", "template")

    def __init__(self, template: Template, take: bool) -> None:
        self.template = template
        self.take = take
        self.done = False
        self.result: Tup = ()

    def wake(self) -> None:
        raise NotImplementedError


class _ThreadWaiter(_Waiter):
    __slots__ = ("lock",)

    def __init__(self, template: Template, take: bool) -> None:
        super().__init__(template, take)
        # A raw lock held from the start: the waiter blocks acquiring it again and the
        # writer releases it. Cheaper than an Event, which wraps a Condition.
        self.lock = threading.Lock()
        self.lock.acquire()

    def wake(self) -> None:
        self.lock.release()


class _TaskWaiter(_Waiter):
    __slots__ = ("future", "loop", "thread")

    def __init__(self, template: Template, take: bool, loop: asyncio.AbstractEventLoop) -> None:
        super().__init__(template, take)
        self.loop = loop
        self.thread = threading.get_ident()
        self.future: asyncio.Future[Tup] = loop.create_future()

    def wake(self) -> None:
        if threading.get_ident() == self.thread:
            self._resolve()
        else:
            self.loop.call_soon_threadsafe(self._resolve)

    def _resolve(self) -> None:
        if not self.future.done():  # the task may have been cancelled meanwhile
            self.future.set_result(self.result)


class NotifyHandle:
    """A registered ``notify`` observer; ``cancel()`` stops further callbacks.

    Also a context manager that cancels on exit.
    """

    __slots__ = ("_space", "active", "callback", "kinds", "template")

    def __init__(
        self, space: TupleSpace, template: Template, kinds: frozenset[str], callback: Callback
    ) -> None:
        self._space = space
        self.template = template
        self.kinds = kinds
        self.callback = callback
        self.active = True
        """False once cancelled."""

    def cancel(self) -> None:
        """Stop calling the callback (idempotent); no call starts after this returns."""
        self.active = False
        self._space._unregister(self)

    def __enter__(self) -> NotifyHandle:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.cancel()

    def __repr__(self) -> str:
        state = "active" if self.active else "cancelled"
        return f"<NotifyHandle {self.template.fields!r} on={sorted(self.kinds)} {state}>"


_AfterItem = _Waiter | tuple[NotifyHandle, str, Tup]


class TupleSpace:
    """A local Linda tuplespace shared by threads and asyncio tasks.

    Args:
        clock: returns the current time in seconds; leases are measured with it. Pass a
            simulation's virtual clock to drive leases in virtual time. Timeouts of
            blocking calls are always real time.
    """

    def __init__(self, *, clock: Callable[[], float] = time.monotonic) -> None:
        self._clock = clock
        self._lock = threading.Lock()
        self._seq = itertools.count()
        self._arities: dict[int, _Arity] = {}
        self._leases: dict[int, tuple[float, list[Any]]] = {}
        # (end, seq); entries of tuples taken before their end stay until popped.
        self._heap: list[tuple[float, int]] = []
        self._waiters: dict[_Waiter, None] = {}
        self._observers: dict[NotifyHandle, None] = {}
        self._after: list[_AfterItem] = []
        self._emptied = 0
        self._sweep_at = 1024
        # The stamp of the latest store or removal, by hashable first field (``version``):
        # stamps grow with every change of any key, so no key's version ever comes back.
        self._versions: dict[Any, int] = {}
        self._stamps = itertools.count(1)

    # -- writing -------------------------------------------------------------------

    def out(self, tup: Tup, lease: float | None = None) -> None:
        """Write ``tup``; a blocked reader or taker waiting for it gets it first.

        Args:
            tup: the tuple to write.
            lease: seconds (by the space's clock) the tuple lives; ``None`` for ever.

        Raises:
            TypeError: ``tup`` is not a tuple.
            ValueError: ``lease`` is negative.
        """
        if type(tup) is not tuple and not isinstance(tup, tuple):
            raise TypeError(f"out() takes a tuple, got {tup!r}")
        if lease is not None and not lease >= 0:
            raise ValueError(f"lease must be >= 0 seconds, got {lease!r}")
        with self._lock:
            if self._heap:
                self._drop_ended()
            if self._observers:
                self._emit("out", tup)
            if not (self._waiters and self._offer(tup)):
                if lease is None:
                    self._store(tup)
                else:
                    now = self._clock()
                    end = now + lease
                    if end > now:  # a zero lease reaches waiters but is never stored
                        entry = self._store(tup)
                        self._leases[entry[1]] = (end, entry)
                        heapq.heappush(self._heap, (end, entry[1]))
            after = self._drain()
        if after:
            self._flush(after)

    def _store(self, tup: Tup) -> list[Any]:
        n = len(tup)
        a = self._arities.get(n)
        if a is None:
            a = self._arities[n] = _Arity()
        if n:
            try:
                q = a.by_first.get(tup[0])
            except TypeError:
                q = a.unkeyed
            else:
                if q is None:
                    q = a.by_first[tup[0]] = _Queue()
                self._versions[tup[0]] = next(self._stamps)
            entry = [tup, next(self._seq), q]
            q.append(entry)
        else:
            entry = [tup, next(self._seq), None]
        a.all.append(entry)
        return entry

    def _remove(self, a: _Arity, entry: list[Any]) -> None:
        tup = entry[0]
        entry[0] = None
        _unlink(a.all, entry)
        q = entry[2]
        if q is not None:
            _unlink(q, entry)
            if q is not a.unkeyed:
                self._versions[tup[0]] = next(self._stamps)
            if not q and q is not a.unkeyed:
                # Empty buckets stay (a tag that goes empty and back, as a lock or a
                # request does, would otherwise rebuild its bucket every time) and are
                # swept once there have been as many emptyings as buckets.
                self._emptied += 1
                if self._emptied > self._sweep_at:
                    self._sweep()
        if self._leases and self._leases.pop(entry[1], None) is not None:
            self._forget_lease()

    def _sweep(self) -> None:
        buckets = 0
        for a in self._arities.values():
            a.by_first = {key: q for key, q in a.by_first.items() if q}
            buckets += len(a.by_first)
        # A key with no tuple left goes back to version 0, the version of no tuples.
        self._versions = {
            key: v
            for key, v in self._versions.items()
            if any(key in a.by_first for a in self._arities.values())
        }
        self._emptied = 0
        self._sweep_at = max(1024, buckets)

    def _forget_lease(self) -> None:
        # Without this, taken leased tuples would leave heap entries that keep every
        # operation reading the clock and the heap growing without bound.
        if not self._leases:
            self._heap.clear()
        elif len(self._heap) > 64 and len(self._heap) > 2 * len(self._leases):
            self._heap = [(end, seq) for seq, (end, _) in self._leases.items()]
            heapq.heapify(self._heap)

    # -- finding -------------------------------------------------------------------

    def _find(self, t: Template | None, tmpl: Tup) -> tuple[_Arity, list[Any]] | None:
        """The entry of the oldest live tuple matching ``tmpl`` (lock held).

        ``t`` is ``None`` when every field of ``tmpl`` is exact: then a tuple matches
        when it equals ``tmpl``, one C-level comparison (a dead entry holds ``None``,
        which equals no tuple), and nothing was analysed.
        """
        a = self._arities.get(len(tmpl))
        if a is None:
            return None
        hit: list[Any] | None = None
        if t is None:
            if not tmpl:
                for e in a.all:
                    if e[0] is not None:
                        return (a, e)
                return None
            try:
                q = a.by_first.get(tmpl[0])
            except TypeError:  # unhashable first field: scan the arity
                for e in a.all:
                    if e[0] == tmpl:
                        return (a, e)
                return None
            if q is not None:
                for e in q:
                    if e[0] == tmpl:
                        hit = e
                        break
            if a.unkeyed:
                for e in a.unkeyed:
                    if hit is not None and e[1] > hit[1]:
                        break
                    if e[0] == tmpl:
                        return (a, e)
            return None if hit is None else (a, hit)
        matches = t.matches
        if t.keyed:
            q = a.by_first.get(t.key)
            if q is not None:
                rest = t.rest
                for e in q:
                    tup = e[0]
                    if tup is not None and rest(tup):
                        hit = e
                        break
            if a.unkeyed:
                for e in a.unkeyed:
                    if hit is not None and e[1] > hit[1]:
                        break
                    tup = e[0]
                    if tup is not None and matches(tup):
                        return (a, e)
            return None if hit is None else (a, hit)
        for e in a.all:
            tup = e[0]
            if tup is not None and matches(tup):
                return (a, e)
        return None

    def _find_all(self, t: Template) -> tuple[_Arity | None, list[list[Any]]]:
        """The entries of every live tuple matching ``t``, oldest first (lock held)."""
        a = self._arities.get(t.arity)
        if a is None:
            return None, []
        matches = t.matches
        if t.keyed:
            q = a.by_first.get(t.key)
            rest = t.rest
            found = [] if not q else [e for e in q if e[0] is not None and rest(e[0])]
            if a.unkeyed:
                found += [e for e in a.unkeyed if e[0] is not None and matches(e[0])]
                found.sort(key=lambda e: e[1])
            return a, found
        return a, [e for e in a.all if e[0] is not None and matches(e[0])]

    def _take_locked(self, tmpl: Tup, t: Template | None) -> Tup | None:
        if self._heap:
            self._drop_ended()
        hit = self._find(t, tmpl)
        if hit is None:
            return None
        a, entry = hit
        tup: Tup = entry[0]
        self._remove(a, entry)
        if self._observers:
            self._emit("in", tup)
        return tup

    def _read_locked(self, tmpl: Tup, t: Template | None) -> Tup | None:
        if self._heap:
            self._drop_ended()
        hit = self._find(t, tmpl)
        return None if hit is None else hit[1][0]

    # -- non-blocking reads and takes ----------------------------------------------

    def inp(self, tmpl: Tup) -> Tup | None:
        """Take the oldest tuple matching ``tmpl``, or return ``None`` if none does.

        Raises:
            TypeError: ``tmpl`` is not a tuple.
        """
        # The hot path: _analyse and _take_locked inlined.
        exact = type(tmpl) is tuple and not any(map(callable, tmpl))
        t = None if exact else compile_template(tmpl)
        with self._lock:
            if self._heap:
                self._drop_ended()
            hit = self._find(t, tmpl)
            if hit is None:
                tup = None
            else:
                a, entry = hit
                tup = entry[0]
                self._remove(a, entry)
                if self._observers:
                    self._emit("in", tup)
            after = self._drain()
        if after:
            self._flush(after)
        return tup

    def rdp(self, tmpl: Tup) -> Tup | None:
        """Return (without taking) the oldest tuple matching ``tmpl``, or ``None``.

        Raises:
            TypeError: ``tmpl`` is not a tuple.
        """
        t = _analyse(tmpl)
        with self._lock:
            tup = self._read_locked(tmpl, t)
            after = self._drain()
        if after:
            self._flush(after)
        return tup

    def rd_all(self, tmpl: Tup) -> list[Tup]:
        """Return every tuple matching ``tmpl``, oldest first, without taking them.

        Raises:
            TypeError: ``tmpl`` is not a tuple.
        """
        t = compile_template(tmpl)
        with self._lock:
            if self._heap:
                self._drop_ended()
            _, found = self._find_all(t)
            tups: list[Tup] = [e[0] for e in found] if found else []
            after = self._drain()
        if after:
            self._flush(after)
        return tups

    def in_all(self, tmpl: Tup) -> list[Tup]:
        """Take every tuple matching ``tmpl``; return them oldest first.

        Raises:
            TypeError: ``tmpl`` is not a tuple.
        """
        t = compile_template(tmpl)
        with self._lock:
            if self._heap:
                self._drop_ended()
            a, found = self._find_all(t)
            if found and a is not None:
                tups: list[Tup] = [e[0] for e in found]
                for e in found:
                    self._remove(a, e)
                if self._observers:
                    for tup in tups:
                        self._emit("in", tup)
            else:
                tups = []
            # Most calls find nothing and leave nothing to run (a lock book forgetting
            # what it may not hold): no list handed over, no call to run it.
            after = self._drain()
        if after:
            self._flush(after)
        return tups

    def count(self, tmpl: Tup) -> int:
        """Return how many tuples match ``tmpl``.

        Raises:
            TypeError: ``tmpl`` is not a tuple.
        """
        t = compile_template(tmpl)
        with self._lock:
            if self._heap:
                self._drop_ended()
            _, found = self._find_all(t)
            after = self._drain()
        self._flush(after)
        return len(found)

    def arities(self) -> list[int]:
        """The arities of the live tuples, ascending: with a template of ``ANY`` per
        field, ``rd_all`` reads every tuple of one (what a node's space holds)."""
        with self._lock:
            if self._heap:
                self._drop_ended()
            out = sorted(n for n, a in self._arities.items() if len(a.all) - a.all.dead > 0)
            after = self._drain()
        self._flush(after)
        return out

    def __len__(self) -> int:
        """The number of live tuples."""
        with self._lock:
            if self._heap:
                self._drop_ended()
            n = sum(len(a.all) - a.all.dead for a in self._arities.values())
            after = self._drain()
        self._flush(after)
        return n

    def version(self, key: Any) -> int:
        """A number that stays the same as long as the tuples whose first field is
        ``key`` do: a store or a removal (taken, expired) of one moves it to a value it
        never had, so whatever was worked out from them holds while it is unchanged
        (0: none was ever stored, or the last went a while ago). Tuples whose first
        field cannot be hashed are not followed (a key equal to one, as
        ``frozenset({1})`` is to ``{1}``: ask the tuples themselves).

        Raises:
            TypeError: ``key`` cannot be hashed.
        """
        hash(key)
        with self._lock:
            if self._heap:
                self._drop_ended()  # a lease that ended is a change
            count = self._versions.get(key, 0)
            after = self._drain()
        if after:
            self._flush(after)
        return count

    def __repr__(self) -> str:
        return f"<TupleSpace with {len(self)} tuples>"

    # -- blocking reads and takes --------------------------------------------------

    def rd(self, tmpl: Tup, timeout: float | None = None) -> Tup:
        """Return the oldest tuple matching ``tmpl``, blocking the thread until one exists.

        Args:
            tmpl: the template.
            timeout: real seconds to wait at most; ``None`` waits for ever.

        Raises:
            TimeoutError: nothing matched within ``timeout``.
            TypeError: ``tmpl`` is not a tuple.
            ValueError: ``timeout`` is negative.
        """
        return self._block(tmpl, False, timeout)

    def in_(self, tmpl: Tup, timeout: float | None = None) -> Tup:
        """Take the oldest tuple matching ``tmpl``, blocking the thread until one exists.

        Blocked takers are served in arrival order, threads and tasks together.

        Args:
            tmpl: the template.
            timeout: real seconds to wait at most; ``None`` waits for ever.

        Raises:
            TimeoutError: nothing matched within ``timeout``.
            TypeError: ``tmpl`` is not a tuple.
            ValueError: ``timeout`` is negative.
        """
        return self._block(tmpl, True, timeout)

    def _block(self, tmpl: Tup, take: bool, timeout: float | None) -> Tup:
        if timeout is not None and not timeout >= 0:
            raise ValueError(f"timeout must be >= 0 seconds, got {timeout!r}")
        t = _analyse(tmpl)
        waiter = None
        with self._lock:
            tup = self._take_locked(tmpl, t) if take else self._read_locked(tmpl, t)
            if tup is None:
                waiter = _ThreadWaiter(compile_template(tmpl) if t is None else t, take)
                self._waiters[waiter] = None
            after = self._drain()
        self._flush(after)
        if waiter is None:
            assert tup is not None
            return tup
        if waiter.lock.acquire(True, -1 if timeout is None else timeout):
            return waiter.result
        with self._lock:
            if not waiter.done:
                del self._waiters[waiter]
                raise TimeoutError(f"no tuple matched {tmpl!r} within {timeout} s")
        return waiter.result  # served between the timeout and the lock

    # The timeout parameters mirror rd/in_, and a timeout inside the call can tell a
    # tuple served at the deadline from none at all, which asyncio.timeout outside cannot.
    async def ard(self, tmpl: Tup, timeout: float | None = None) -> Tup:  # noqa: ASYNC109
        """Return the oldest tuple matching ``tmpl``, waiting (asynchronously) for one.

        Args:
            tmpl: the template.
            timeout: seconds to wait at most; ``None`` waits for ever.

        Raises:
            TimeoutError: nothing matched within ``timeout``.
            TypeError: ``tmpl`` is not a tuple.
            ValueError: ``timeout`` is negative.
        """
        return await self._await(tmpl, False, timeout)

    async def ain(self, tmpl: Tup, timeout: float | None = None) -> Tup:  # noqa: ASYNC109
        """Take the oldest tuple matching ``tmpl``, waiting (asynchronously) for one.

        Blocked takers are served in arrival order, threads and tasks together. If the
        task is cancelled after a tuple was handed to it, the tuple is written back
        (without its lease), so it is never lost.

        Args:
            tmpl: the template.
            timeout: seconds to wait at most; ``None`` waits for ever.

        Raises:
            TimeoutError: nothing matched within ``timeout``.
            TypeError: ``tmpl`` is not a tuple.
            ValueError: ``timeout`` is negative.
        """
        return await self._await(tmpl, True, timeout)

    async def _await(self, tmpl: Tup, take: bool, limit: float | None) -> Tup:
        if limit is not None and not limit >= 0:
            raise ValueError(f"timeout must be >= 0 seconds, got {limit!r}")
        t = _analyse(tmpl)
        loop = asyncio.get_running_loop()
        waiter = None
        with self._lock:
            tup = self._take_locked(tmpl, t) if take else self._read_locked(tmpl, t)
            if tup is None:
                waiter = _TaskWaiter(compile_template(tmpl) if t is None else t, take, loop)
                self._waiters[waiter] = None
            after = self._drain()
        self._flush(after)
        if waiter is None:
            assert tup is not None
            return tup
        try:
            if limit is None:
                return await waiter.future
            async with asyncio.timeout(limit):
                return await waiter.future
        except BaseException as exc:
            with self._lock:
                served = waiter.done
                if not served:
                    del self._waiters[waiter]
            if not served:
                if isinstance(exc, TimeoutError):
                    raise TimeoutError(f"no tuple matched {tmpl!r} within {limit} s") from None
                raise
            if isinstance(exc, TimeoutError):
                return waiter.result  # served just as the time ran out
            if take:
                self.out(waiter.result)
            raise

    # -- waking waiters and observers ------------------------------------------------

    def _offer(self, tup: Tup) -> bool:
        """Hand a new tuple to matching waiters in arrival order (lock held).

        Every matching reader up to the first matching taker gets it; returns whether a
        taker took it.
        """
        n = len(tup)
        served = []
        taken = False
        for w in self._waiters:
            t = w.template
            if t.arity != n:
                continue
            try:
                ok = t.matches(tup)
            except Exception:
                _log.exception("template %r of a waiter raised on %r", t.fields, tup)
                continue
            if ok:
                w.result = tup
                w.done = True
                served.append(w)
                if w.take:
                    taken = True
                    break
        for w in served:
            del self._waiters[w]
        self._after += served
        if taken and self._observers:
            self._emit("in", tup)
        return taken

    def _emit(self, kind: str, tup: Tup) -> None:
        n = len(tup)
        for o in self._observers:
            t = o.template
            if kind in o.kinds and t.arity == n:
                try:
                    ok = t.matches(tup)
                except Exception:
                    _log.exception("template %r of an observer raised on %r", t.fields, tup)
                    continue
                if ok:
                    self._after.append((o, kind, tup))

    def _drain(self) -> Sequence[_AfterItem]:
        """Take what waits to run once the lock is released (nothing: no new list)."""
        after = self._after
        if not after:
            return ()
        self._after = []
        return after

    def _flush(self, after: Sequence[_AfterItem]) -> None:
        """Run queued wake-ups and callbacks (lock released)."""
        for item in after:
            if isinstance(item, tuple):
                handle, kind, tup = item
                if not handle.active:
                    continue
                try:
                    handle.callback(kind, tup)
                except Exception:
                    _log.exception("notify callback %r failed on %s %r", handle.callback, kind, tup)
            else:
                try:
                    item.wake()
                except RuntimeError:  # the waiting task's event loop is closed
                    if item.take:
                        self.out(item.result)

    # -- leases ----------------------------------------------------------------------

    def _drop_ended(self) -> int:
        """Remove tuples whose lease ended by now (lock held); queue "expire" events."""
        heap = self._heap
        now = self._clock()
        if heap[0][0] > now:
            return 0
        dropped = 0
        leases = self._leases
        while heap and heap[0][0] <= now:
            end, seq = heapq.heappop(heap)
            entry = leases.get(seq)
            if entry is None or entry[0] != end:
                continue  # already taken
            tup: Tup = entry[1][0]
            self._remove(self._arities[len(tup)], entry[1])
            dropped += 1
            if self._observers:
                self._emit("expire", tup)
        return dropped

    def next_expiry(self) -> float | None:
        """Return the earliest lease end among stored tuples (by the clock), or ``None``."""
        with self._lock:
            heap = self._heap
            while heap:
                end, seq = heap[0]
                entry = self._leases.get(seq)
                if entry is not None and entry[0] == end:
                    return end
                heapq.heappop(heap)
            return None

    def expire(self) -> int:
        """Drop every tuple whose lease has ended by the clock; return how many.

        Observers registered for ``"expire"`` are called for each. Other operations drop
        ended tuples as well (an ended lease never matches), so this counts only those
        no earlier call dropped.
        """
        with self._lock:
            dropped = self._drop_ended() if self._heap else 0
            after = self._drain()
        self._flush(after)
        return dropped

    # -- observers -------------------------------------------------------------------

    def notify(
        self, tmpl: Tup, callback: Callback, on: Iterable[str] | str = ("out", "in")
    ) -> NotifyHandle:
        """Call ``callback(kind, tup)`` for every event on a tuple matching ``tmpl``.

        Kinds are ``"out"`` (written), ``"in"`` (taken) and ``"expire"`` (lease ended).
        A lease's end is noticed at the space's next access or ``expire()`` call, not by
        a timer: to hear it on time, call ``expire()`` when the lease ends (e.g. with the
        node's ``call_later``). Callbacks run in the thread that caused the event,
        outside the space's lock, so they may use the space. A callback that raises is
        logged (logger ``"tuplespace"``) and the space carries on.

        Args:
            tmpl: the template.
            callback: called as ``callback(kind, tup)``.
            on: the kinds to report.

        Returns:
            A handle whose ``cancel()`` stops the callbacks.

        Raises:
            TypeError: ``tmpl`` is not a tuple or ``callback`` is not callable.
            ValueError: ``on`` names an unknown kind.
        """
        kinds = frozenset((on,) if isinstance(on, str) else on)
        if not kinds <= KINDS:
            raise ValueError(f"unknown event kind(s) {sorted(kinds - KINDS)!r}")
        if not callable(callback):
            raise TypeError(f"callback must be callable, got {callback!r}")
        handle = NotifyHandle(self, compile_template(tmpl), kinds, callback)
        self._register(handle)
        return handle

    def _register(self, handle: NotifyHandle) -> None:
        with self._lock:
            self._observers[handle] = None

    def _unregister(self, handle: NotifyHandle) -> None:
        with self._lock:
            self._observers.pop(handle, None)

    def watch(self, tmpl: Tup, *, maxsize: int = 10_000) -> Watch:
        """Iterate asynchronously over tuples matching ``tmpl`` written from now on.

        Call it from a running event loop. Close the iterator (``aclose()``, or use it
        as ``async with``) when done; one that is merely dropped stops receiving at the
        next matching write.

        Args:
            tmpl: the template.
            maxsize: tuples buffered at most before the iterator gives up.

        Raises:
            RuntimeError: no event loop is running.
            TypeError: ``tmpl`` is not a tuple.
            ValueError: ``maxsize`` is below 1.
        """
        from ._watch import Watch  # here: the watch module imports this one

        return Watch(self, tmpl, maxsize=maxsize)
