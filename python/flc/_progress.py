"""Progress on stderr for the long Python commands (``python -m flc sweep`` / ``figures``), as the
``scenario`` binary's indicatif bar: drawn only when stderr is a terminal, so logs and pipes stay
clean; ``--quiet`` (or ``progress=False``) turns it off."""
from __future__ import annotations

import sys
import time
from typing import Any, Callable, Optional, TextIO, Union

#: What the ``progress`` arguments take: ``None`` (a bar when stderr is a terminal), ``False``
#: (none), ``True`` (a bar on stderr even when it is not a terminal) or a callable.
ProgressArg = Union[None, bool, Callable[[int, int], None]]


def stderr_is_terminal() -> bool:
    isatty = getattr(sys.stderr, "isatty", None)
    try:
        return bool(isatty and isatty())
    except (ValueError, OSError):  # closed or detached stream
        return False


class Bar:
    """``done / total what elapsed`` redrawn in place on ``stream`` (default stderr), at most 10
    times a second; :meth:`close` ends the line."""

    def __init__(self, total: int, what: str = "runs", stream: Optional[TextIO] = None) -> None:
        self.total = max(0, int(total))
        self.what = what
        self.stream = stream if stream is not None else sys.stderr
        self.t0 = time.monotonic()
        self._last = -1.0
        self._shown = False

    def __call__(self, done: int, total: Optional[int] = None, label: str = "") -> None:
        if total is not None:
            self.total = int(total)
        now = time.monotonic()
        if done < self.total and now - self._last < 0.1:
            return
        self._last = now
        width = 30
        filled = width if self.total <= 0 else min(width, int(width * done / self.total))
        el = int(now - self.t0)
        extra = f" {label}" if label else ""
        self.stream.write(f"\r[{'#' * filled}{' ' * (width - filled)}] {done}/{self.total} {self.what} {el // 60:02d}:{el % 60:02d}{extra}\x1b[K")
        self.stream.flush()
        self._shown = True

    def close(self) -> None:
        if self._shown:
            self.stream.write("\n")
            self.stream.flush()
            self._shown = False


def resolve(progress: ProgressArg, total: int, what: str = "runs") -> tuple[Optional[Callable[[int, int], None]], Optional[Bar]]:
    """The callback for a ``progress`` argument and the bar to close (``None`` without one)."""
    if callable(progress) and not isinstance(progress, bool):
        return progress, None
    if progress is False or (progress is None and not stderr_is_terminal()):
        return None, None
    bar = Bar(total, what)
    return bar, bar


def call(cb: Optional[Callable[..., Any]], *args: Any) -> None:
    if cb is not None:
        cb(*args)
