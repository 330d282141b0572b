"""structlog configuration: human-readable on a terminal, JSON lines otherwise."""

from __future__ import annotations

import logging
import sys
from typing import Literal

import structlog

__all__ = ["configure_logging"]


class _StderrLogger:
    """Writes each rendered line to whatever ``sys.stderr`` is *now*.

    Binding the stream once (as ``PrintLoggerFactory(file=sys.stderr)`` does) breaks when a
    caller swaps stderr, e.g. a test runner capturing output, and later closes its buffer.
    """

    def msg(self, message: str) -> None:
        print(message, file=sys.stderr, flush=True)

    debug = info = warning = warn = error = critical = exception = fatal = msg


def _stderr_logger_factory(*_args: object) -> _StderrLogger:
    return _StderrLogger()

LogLevel = Literal["debug", "info", "warning", "error"]


def configure_logging(level: LogLevel | str = "warning", *, json_lines: bool | None = None) -> None:
    """Configure structlog for the process.

    ``json_lines=None`` picks JSON lines when stderr is not a terminal (CI, batch jobs, log
    collectors) and coloured console output when it is. Logs go to stderr so that stdout stays
    free for command output.
    """
    numeric = logging.getLevelNamesMapping().get(str(level).upper())
    if numeric is None:
        raise ValueError(f"unknown log level {level!r}; use debug, info, warning or error")
    if json_lines is None:
        json_lines = not sys.stderr.isatty()
    renderer: structlog.types.Processor = (
        structlog.processors.JSONRenderer(sort_keys=True) if json_lines else structlog.dev.ConsoleRenderer()
    )
    structlog.configure(
        processors=[
            structlog.contextvars.merge_contextvars,
            structlog.processors.add_log_level,
            structlog.processors.TimeStamper(fmt="iso", utc=True),
            structlog.processors.format_exc_info,
            renderer,
        ],
        wrapper_class=structlog.make_filtering_bound_logger(numeric),
        logger_factory=_stderr_logger_factory,
        cache_logger_on_first_use=False,
    )
