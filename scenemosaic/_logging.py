"""structlog configuration: readable lines wherever a person reads them, JSON lines when asked.

``text`` (the default) writes one plain line per event, ``warning: event key=value ...``, coloured
only on a terminal: a terminal, a notebook cell, a pipe into a log file and CI all read the same.
``json`` writes one JSON object a line (log collectors; the batch workers' per-job logs).

In ``text``, warnings and errors of one kind that come one after another are folded into one
line with their count and, for each field that differs, the list of values
(``warning: unknown_procedural_category ×5 category=[toilet, sink, ...] fallback=box``); the line
is written when another event comes, or at :func:`flush_logs` (the CLI calls it after each stage
and at the end; it also runs at exit). Events a caller reports itself (``suppress``: the CLI's
own summary of a degraded run, a failed or interrupted stage) are left out, so nothing is printed
twice.
"""

from __future__ import annotations

import atexit
import json
import logging
import sys
from collections.abc import Collection, MutableMapping
from typing import Any, Literal

import structlog

__all__ = ["LOG_FORMATS", "LogFormat", "configure_logging", "flush_logs"]

LogFormat = Literal["text", "json"]
LOG_FORMATS: tuple[str, ...] = ("text", "json")
"""The values of ``--log-format``."""

LogLevel = Literal["debug", "info", "warning", "error"]

_FOLDED_LEVELS = frozenset({"warning", "error", "critical"})
_MAX_LISTED = 12
"""Values listed per field of a folded line; more are counted (``... +3``)."""
_COLOURS = {"warning": "\x1b[33m", "error": "\x1b[31m", "critical": "\x1b[31m"}
_RESET = "\x1b[0m"


class _StderrLogger:
    """Writes each rendered line to whatever ``sys.stderr`` is *now*.

    Binding the stream once (as ``PrintLoggerFactory(file=sys.stderr)`` does) breaks when a
    caller swaps stderr, e.g. a test runner capturing output, and later closes its buffer.
    """

    def msg(self, message: str) -> None:
        if message:
            print(message, file=sys.stderr, flush=True)

    debug = info = warning = warn = error = critical = exception = fatal = msg


def _stderr_logger_factory(*_args: object) -> _StderrLogger:
    return _StderrLogger()


def _value(value: Any) -> str:
    if isinstance(value, str):
        return value if value and " " not in value and "=" not in value else json.dumps(value)
    return json.dumps(value, default=str, ensure_ascii=False) if isinstance(value, dict | list) else str(value)


class _TextRenderer:
    """``level: event key=value ...`` (no timestamp: a person reads it as it comes), with runs of
    one warning or error kind folded into one line."""

    def __init__(self) -> None:
        self._pending: list[dict[str, Any]] = []

    def line(self, events: list[dict[str, Any]]) -> str:
        first = events[0]
        level = str(first.get("level", "info"))
        head = f"{level}: {first.get('event', '')}"
        if len(events) > 1:
            head += f" ×{len(events)}"
        fields: list[str] = []
        keys = [k for k in first if k not in ("event", "level", "timestamp")]
        for event in events[1:]:
            keys += [k for k in event if k not in keys and k not in ("event", "level", "timestamp")]
        for key in keys:
            values: list[str] = []
            for event in events:
                if key in event and _value(event[key]) not in values:
                    values.append(_value(event[key]))
            if len(values) == 1:
                fields.append(f"{key}={values[0]}")
            else:
                listed = ", ".join(values[:_MAX_LISTED]) + (f", ... +{len(values) - _MAX_LISTED}" if len(values) > _MAX_LISTED else "")
                fields.append(f"{key}=[{listed}]")
        text = " ".join([head, *fields])
        if level in _COLOURS and sys.stderr.isatty():
            return f"{_COLOURS[level]}{level}{_RESET}{text[len(level):]}"
        return text

    def flush(self) -> str:
        pending, self._pending = self._pending, []
        return self.line(pending) if pending else ""

    def __call__(self, _logger: object, _name: str, event_dict: MutableMapping[str, Any]) -> str:
        event = dict(event_dict)
        key = (event.get("level"), event.get("event"))
        if self._pending and (self._pending[0].get("level"), self._pending[0].get("event")) == key:
            self._pending.append(event)
            return ""
        earlier = self.flush()
        if event.get("level") in _FOLDED_LEVELS:
            self._pending = [event]
            return earlier
        return "\n".join(line for line in (earlier, self.line([event])) if line)


_text_renderer: _TextRenderer | None = None


def flush_logs() -> None:
    """Write the folded line of the warnings still held (a no-op in ``json`` or with none held)."""
    if _text_renderer is not None:
        _StderrLogger().msg(_text_renderer.flush())


atexit.register(flush_logs)


def _suppressor(names: frozenset[str]) -> structlog.types.Processor:
    def suppress(_logger: object, _name: str, event_dict: MutableMapping[str, Any]) -> MutableMapping[str, Any]:
        if event_dict.get("event") in names:
            raise structlog.DropEvent
        return event_dict

    return suppress


def configure_logging(
    level: LogLevel | str = "warning",
    *,
    log_format: LogFormat | str = "text",
    json_lines: bool | None = None,
    suppress: Collection[str] = (),
) -> None:
    """Configure structlog for the process; logs go to stderr, so stdout stays free for output.

    ``log_format`` is ``text`` (readable lines, warnings of one kind folded: see the module
    docstring) or ``json`` (one JSON object a line, with a UTC timestamp). ``json_lines=True``
    is ``log_format="json"`` (kept for the batch workers' log files). ``suppress`` names events
    the caller reports itself, left out of the log.
    """
    global _text_renderer
    numeric = logging.getLevelNamesMapping().get(str(level).upper())
    if numeric is None:
        raise ValueError(f"unknown log level {level!r}; use debug, info, warning or error")
    if json_lines is not None:
        log_format = "json" if json_lines else "text"
    if log_format not in LOG_FORMATS:
        raise ValueError(f"unknown log format {log_format!r}; use text or json")
    flush_logs()  # what the previous configuration still held
    processors: list[structlog.types.Processor] = [
        structlog.contextvars.merge_contextvars,
        structlog.processors.add_log_level,
    ]
    if suppress:
        processors.append(_suppressor(frozenset(suppress)))
    if log_format == "json":
        _text_renderer = None
        processors += [
            structlog.processors.TimeStamper(fmt="iso", utc=True),
            structlog.processors.format_exc_info,
            structlog.processors.JSONRenderer(sort_keys=True),
        ]
    else:
        _text_renderer = _TextRenderer()
        processors += [structlog.processors.format_exc_info, _text_renderer]
    structlog.configure(
        processors=processors,
        wrapper_class=structlog.make_filtering_bound_logger(numeric),
        logger_factory=_stderr_logger_factory,
        cache_logger_on_first_use=False,
    )
