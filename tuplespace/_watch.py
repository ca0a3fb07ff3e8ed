"""``TupleSpace.watch``: an async iterator over the tuples written from now on."""

from __future__ import annotations

import asyncio
import threading
import weakref
from collections import deque
from types import TracebackType
from typing import TYPE_CHECKING

from mypy_extensions import mypyc_attr

from ._match import compile_template
from ._space import NotifyHandle, Tup
from .errors import WatchOverflow

if TYPE_CHECKING:
    from ._space import TupleSpace

__all__ = ["Watch"]


# Not a native class when compiled: it is held by a weak reference.
@mypyc_attr(native_class=False)
class Watch:
    """Async iterator over tuples written to a space that match a template.

    Raises ``WatchOverflow`` (after yielding what it buffered) when more than
    ``maxsize`` tuples arrived unconsumed.
    """

    def __init__(self, space: TupleSpace, tmpl: Tup, *, maxsize: int) -> None:
        if maxsize < 1:
            raise ValueError(f"maxsize must be >= 1, got {maxsize!r}")
        self._loop = asyncio.get_running_loop()
        self._owner_thread = threading.get_ident()
        self._buffer: deque[Tup] = deque()
        self._maxsize = maxsize
        self._overflowed = False
        self._closed = False
        self._wakeup: asyncio.Future[None] | None = None
        # The observer holds the watch weakly so a watch that is dropped without being
        # closed unregisters itself at the next event instead of living for ever.
        ref = weakref.ref(self)

        def deliver(kind: str, tup: Tup) -> None:
            watch = ref()
            if watch is None:
                handle.cancel()
            elif threading.get_ident() == watch._owner_thread:
                watch._push(tup)
            else:
                try:
                    watch._loop.call_soon_threadsafe(watch._push, tup)
                except RuntimeError:  # its loop is closed
                    handle.cancel()

        handle = NotifyHandle(space, compile_template(tmpl), frozenset({"out"}), deliver)
        self._handle = handle
        space._register(handle)

    def _push(self, tup: Tup) -> None:
        if self._closed:
            return
        if len(self._buffer) >= self._maxsize:
            self._overflowed = True
            self._handle.cancel()
        else:
            self._buffer.append(tup)
        if self._wakeup is not None and not self._wakeup.done():
            self._wakeup.set_result(None)

    def __aiter__(self) -> Watch:
        return self

    async def __anext__(self) -> Tup:
        while not self._buffer:
            if self._overflowed:
                self.close()
                raise WatchOverflow(f"more than {self._maxsize} tuples arrived unconsumed")
            if self._closed:
                raise StopAsyncIteration
            self._wakeup = self._loop.create_future()
            try:
                await self._wakeup
            finally:
                self._wakeup = None
        return self._buffer.popleft()

    def close(self) -> None:
        """Stop watching; a pending ``__anext__`` ends the iteration."""
        self._closed = True
        self._handle.cancel()
        if self._wakeup is not None and not self._wakeup.done():
            self._wakeup.set_result(None)

    async def aclose(self) -> None:
        """Stop watching (the async spelling of ``close``)."""
        self.close()

    async def __aenter__(self) -> Watch:
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()
