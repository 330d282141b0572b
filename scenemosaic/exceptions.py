"""The one exception tree of scenemosaic.

Every error the library raises on purpose derives from :class:`SceneMosaicError`.
Usage errors (the caller gave us something wrong) are kept apart from run errors
(something failed while working on valid input)::

    SceneMosaicError
    ├── UsageError                      the caller's input or configuration is wrong
    │   ├── SceneValidationError        a scene breaks the model's rules (NaN pose, duplicate id, ...)
    │   ├── ImportFormatError           an input file is malformed (names file and field)
    │   ├── AssetError                  a mesh cannot be loaded or is degenerate
    │   │   └── UnsafePathError         a file reference leaves its allowed folders, or cannot be resolved
    │   ├── GraphDefinitionError        a task graph has a cycle, a missing dependency, a duplicate name
    │   │   └── GraphChangedError       a run store belongs to another graph definition
    │   ├── ModelConfigError            a model string or model setting is wrong (e.g. vision on a text-only server)
    │   │   └── ModelEndpointError      the model server cannot serve this run: nothing listening, unknown
    │   │                               host, key refused (401/403), no such model or path (404)
    │   ├── ExpressionError             a pose expression is refused by the sandboxed evaluator
    │   ├── OutputSpaceError            the output's disk is full: a file could not be written (also an OSError)
    │   ├── PartialResultError          a folder holds what a failed or stopped run kept, not a delivered scene
    │   └── MissingExtraError           an optional dependency is not installed (names the pip command)
    └── RunError                        something failed while running on valid input
        ├── NodeFailedError             a task-graph node failed after its retries
        ├── NodeTimeoutError            a node ran past its timeout
        ├── RunCancelledError           a run was cancelled; carries the partial results
        ├── UsageLimitExceeded          a usage limit (requests, tokens, cost) stopped the run
        ├── ModelError                  a model request failed
        │   ├── ModelHTTPError          non-200 reply; carries status code and body
        │   │   └── ModelContextLengthError  the prompt does not fit the model's context window
        │   ├── OutputValidationError   reply not JSON / breaks the schema; carries raw reply and errors
        │   ├── ReplayMissError         replay mode found no cassette entry; names the differing part
        │   ├── ModelDeadlineExceeded   the run's model deadline has passed; nothing was sent
        │   └── ModelUnavailableError   a circuit breaker holds requests back from a failing endpoint
        ├── AgentOutputError            a validated agent output is inconsistent with the scene
        │                               (unknown object id, parent cycle, support by a leaf)
        ├── PhysicsError                simulation failed (blow-up that no fallback could fix)
        └── StageOrderError             a stage needs a result no earlier stage made (a bug in a stage list)
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "AgentOutputError",
    "AssetError",
    "BackendError",
    "ExpressionError",
    "GraphChangedError",
    "GraphDefinitionError",
    "ImportFormatError",
    "MissingExtraError",
    "ModelConfigError",
    "ModelContextLengthError",
    "ModelDeadlineExceeded",
    "ModelEndpointError",
    "ModelError",
    "ModelHTTPError",
    "ModelUnavailableError",
    "NodeFailedError",
    "NodeTimeoutError",
    "OutputSpaceError",
    "OutputValidationError",
    "PartialResultError",
    "PhysicsError",
    "ReplayMissError",
    "RunCancelledError",
    "RunError",
    "SceneMosaicError",
    "SceneValidationError",
    "StageOrderError",
    "UnsafePathError",
    "UsageError",
    "UsageLimitExceeded",
]


class SceneMosaicError(Exception):
    """Root of every error scenemosaic raises on purpose."""


class UsageError(SceneMosaicError):
    """The caller's input or configuration is wrong; fixing the input fixes the error."""


class SceneValidationError(UsageError):
    """A scene (or part of one) breaks the scene model's rules.

    Deliberately not a ``ValueError``: raised inside a pydantic validator it propagates
    as itself instead of being folded into a ``pydantic.ValidationError``.

    ``object_id`` names the offending object when there is one.
    """

    def __init__(self, message: str, *, object_id: str | None = None) -> None:
        super().__init__(message)
        self.object_id = object_id


class ImportFormatError(UsageError, ValueError):
    """An input file is malformed. The message names the file and the field."""

    def __init__(self, message: str, *, path: str | None = None, field: str | None = None) -> None:
        parts = [p for p in (path, field) if p]
        prefix = ": ".join(parts)
        super().__init__(f"{prefix}: {message}" if prefix else message)
        self.path = path
        self.field = field


class ExpressionError(UsageError):
    """A pose expression (``chair_0.center.u = table_0.bbox.max_u + 0.05``) is refused.

    Raised by the sandboxed evaluator for anything outside the expression grammar, unknown ids,
    objects that may not change, and values out of range; ``problems`` holds one message per
    refused line, written to be sent back to the model (or shown to the user) as they are.
    """

    def __init__(self, message: str, *, problems: list[str] | None = None) -> None:
        super().__init__(message)
        self.problems = problems or [message]


class AssetError(UsageError):
    """A mesh cannot be loaded, is degenerate, or cannot be decomposed."""


class GraphDefinitionError(UsageError):
    """A task graph is malformed: a cycle, a missing dependency or a duplicate node name."""


class GraphChangedError(GraphDefinitionError):
    """A run store holds outputs of a different graph definition; ``differences`` lists the changes."""

    def __init__(self, message: str, *, differences: list[str]) -> None:
        super().__init__(message)
        self.differences = list(differences)


class ModelConfigError(UsageError):
    """A model string or model setting is wrong (unknown scheme, vision on a text-only server...)."""


class ModelEndpointError(ModelConfigError):
    """The model server named by the run cannot serve it, and waiting will not change that:
    nothing listens at the address, the host is unknown, the key is refused (401/403), or the
    model or path is not there (404). Never retried; the run stops with the fix in one line,
    unless the run asked to fall back to the rule solvers (``--fallback rules``).
    ``url`` is the server's address; ``status_code`` the HTTP status (``None``: no connection)."""

    def __init__(self, message: str, *, url: str, status_code: int | None = None) -> None:
        super().__init__(message)
        self.url = url
        self.status_code = status_code


class OutputSpaceError(UsageError, OSError):
    """No space left on the device (or over quota) while writing ``path``: nothing half-written is
    left behind, and the message says to free space or choose another ``--out``. It is also an
    ``OSError`` (``errno`` ``ENOSPC`` or ``EDQUOT``), so code that tolerates a failed write (a
    cache) still does. ``report``: the run's report, kept in memory when it could not be written."""

    def __init__(self, path: str, error_number: int) -> None:
        message = f"no space left on device writing {path}: free space, or choose another --out"
        OSError.__init__(self, error_number, message)
        self.path = path
        self.report: dict[str, Any] | None = None

    def __str__(self) -> str:
        return str(self.strerror)


class PartialResultError(UsageError):
    """A folder holds the partial result of a failed or stopped run (``partial.json`` beside its
    scene), not a delivered scene: loaders refuse it unless asked for a partial result
    (``allow_partial=True``, ``--allow-partial``). ``marker``: what ``partial.json`` says."""

    def __init__(self, folder: str, marker: dict[str, Any]) -> None:
        status = marker.get("status") or "failed"
        stage = marker.get("failed_stage")
        where = f" in stage {stage!r}" if stage else ""
        super().__init__(
            f"{folder} holds the partial result of a run that {'was interrupted' if status == 'interrupted' else 'failed'}{where}, "
            "not a delivered scene; resume the run (--resume), or load it anyway with allow_partial=True (--allow-partial)"
        )
        self.folder = folder
        self.marker = marker


class MissingExtraError(UsageError, ImportError):
    """An optional dependency is missing; the message names the ``pip install`` to run."""


class RunError(SceneMosaicError):
    """Something failed while working on valid input."""


class NodeFailedError(RunError):
    """A task-graph node failed after exhausting its retry policy."""

    def __init__(self, node: str, cause: BaseException, *, partial: dict[str, Any] | None = None) -> None:
        super().__init__(f"node {node!r} failed: {type(cause).__name__}: {cause}")
        self.node = node
        self.cause = cause
        self.partial: dict[str, Any] = dict(partial or {})


class NodeTimeoutError(RunError, TimeoutError):
    """A node ran longer than its timeout policy allows."""

    def __init__(self, node: str, timeout_s: float, *, partial: dict[str, Any] | None = None) -> None:
        super().__init__(f"node {node!r} timed out after {timeout_s:g} s")
        self.node = node
        self.timeout_s = timeout_s
        self.partial: dict[str, Any] = dict(partial or {})


class RunCancelledError(RunError):
    """A run was cancelled. ``partial`` holds every node output computed before the cancel."""

    def __init__(self, message: str, *, partial: dict[str, Any] | None = None) -> None:
        super().__init__(message)
        self.partial: dict[str, Any] = dict(partial or {})


class UsageLimitExceeded(RunError):
    """A usage limit (requests, tokens, cost) was reached; the run stopped cleanly."""

    def __init__(self, message: str, *, partial: dict[str, Any] | None = None) -> None:
        super().__init__(message)
        self.partial: dict[str, Any] = dict(partial or {})


class BackendError(RunError):
    """A perception backend (a segmenter, a reconstructor, an image endpoint) failed or answered
    something unusable; the message names the backend and what it returned."""


class ModelError(RunError):
    """A model request failed."""


class ModelHTTPError(ModelError):
    """An HTTP reply other than 200 (or a 200 carrying an error object)."""

    def __init__(self, message: str, *, status_code: int, body: str) -> None:
        super().__init__(f"HTTP {status_code}: {message}")
        self.status_code = status_code
        self.body = body


class OutputValidationError(ModelError):
    """A model reply was not JSON or broke the output schema.

    ``raw_reply`` is the reply as text, ``errors`` the problems in words (what a repair request
    sends back), ``usage`` the tokens the failed call cost (a ``scenemosaic.models.Usage``).
    """

    def __init__(self, message: str, *, raw_reply: str, errors: list[str] | None = None, usage: Any = None) -> None:
        super().__init__(message)
        self.raw_reply = raw_reply
        self.errors = list(errors or [])
        self.usage = usage  # a scenemosaic.models.Usage, or None when unknown (this module imports nothing)


class ReplayMissError(ModelError, KeyError):
    """Replay mode found no recorded reply for a request; ``differing`` names what changed."""

    def __init__(self, message: str, *, differing: list[str] | None = None) -> None:
        super().__init__(message)
        self.differing = list(differing or [])

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


class AgentOutputError(RunError):
    """An agent's schema-valid output is inconsistent with the scene.

    Examples: it names an object id that does not exist, it would create a parent
    cycle, it puts an object on a leaf that cannot support it. ``problems`` lists
    each issue in words a model can act on (they are sent back in repair requests).
    """

    def __init__(self, message: str, *, agent: str | None = None, problems: list[str] | None = None) -> None:
        super().__init__(message)
        self.agent = agent
        self.problems = list(problems or [])


class StageOrderError(RunError):
    """A pipeline stage asked for a result that no earlier stage made (the scene before import,
    the house in a room's run): a bug in a stage list, not bad input."""


class PhysicsError(RunError):
    """A simulation failed in a way no fallback could fix."""

    def __init__(self, message: str, *, object_ids: list[str] | None = None) -> None:
        super().__init__(message)
        self.object_ids = list(object_ids or [])


class ModelContextLengthError(ModelHTTPError):
    """The prompt does not fit the model's context window.

    Raised for a server's refusal (llama.cpp's ``exceed_context_size_error``, OpenAI's
    ``context_length_exceeded``) and, with ``sent`` false, when the client's own estimate
    shows the prompt clearly cannot fit, before anything is sent. ``prompt_tokens`` and
    ``context_tokens`` are the sizes when known (the server's figures, or the estimate).
    """

    def __init__(
        self,
        message: str,
        *,
        status_code: int,
        body: str,
        prompt_tokens: int | None = None,
        context_tokens: int | None = None,
        sent: bool = True,
    ) -> None:
        if sent:
            super().__init__(message, status_code=status_code, body=body)
        else:  # refused before sending: no "HTTP <status>" prefix, since no server said it
            ModelError.__init__(self, message)
            self.status_code = status_code
            self.body = body
        self.prompt_tokens = prompt_tokens
        self.context_tokens = context_tokens
        self.sent = sent


class ModelDeadlineExceeded(ModelError):
    """The run's deadline for model requests has passed (or passed while a request was running)."""


class ModelUnavailableError(ModelError):
    """A circuit breaker refused a request without sending it: the endpoint kept failing.

    ``model`` names the model (and its endpoint when known), ``last_error`` the failure that
    opened the circuit, ``retry_in_s`` how long until a trial request is let through.
    """

    def __init__(self, message: str, *, model: str, last_error: str, retry_in_s: float) -> None:
        super().__init__(message)
        self.model = model
        self.last_error = last_error
        self.retry_in_s = retry_in_s


class UnsafePathError(AssetError):
    """A file reference would read outside the folders it may use, or cannot be resolved.

    Raised for a scene's mesh uri, or a file a mesh references (glTF buffers and images, OBJ
    material libraries and textures), whose resolved path (symlinks followed) lies outside the
    allowed folders, for a URL where a file path is expected, and for a symlink loop. ``reference``
    is the text as written in the file; ``resolved`` the path it leads to, when that is known.
    """

    def __init__(self, message: str, *, reference: str, resolved: str | None = None) -> None:
        super().__init__(message)
        self.reference = reference
        self.resolved = resolved
