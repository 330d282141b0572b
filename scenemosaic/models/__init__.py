"""The VLM seam: one abstract ``Model.request`` and everything that implements or wraps it.

Models that answer:

* :class:`RulesModel` (``"rules"``) — offline: each agent answers with its own rule solver.
* :class:`OpenAIChatModel` (``"openai:<model>[@<base_url>]"``) — any OpenAI-compatible
  Chat Completions server, with transport retries (agents repair bad replies).
* :class:`FunctionModel` — Python callables per agent (tests, scripts).

Wrappers that add behaviour around any model:

* :class:`ReplayModel` — record / replay replies in a JSON cassette.
* :class:`LimitedModel` — shared concurrency and request/token rate limits.
* :class:`InstrumentedModel` — a :class:`ModelCall` record per request.
* :class:`DeadlineModel` — one wall-clock budget for all requests of a run.
* :class:`CircuitBreakerModel` — refuse requests at once while an endpoint keeps failing.

:class:`QualityBreaker` stops asking for a kind of answer (an agent's) the model keeps getting
wrong; the agents report to it.

:func:`parse_model` builds any of these from a string; :func:`open_run_model` builds the one
stack a ``generate`` run asks (wrappers, limits, breaker, deadline, usage) for its whole length.
"""

from scenemosaic.models._base import ImagePart, Message, Model, ModelSettings, RequestContext, TextPart, Usage
from scenemosaic.models._cache import CachedModel
from scenemosaic.models._circuit import CircuitBreakerModel, CircuitState
from scenemosaic.models._completion import Completion, CompletionModel
from scenemosaic.models._deadline import DeadlineModel
from scenemosaic.models._function import AgentFunction, FunctionModel
from scenemosaic.models._http import (
    CallClock,
    GiveUp,
    HTTPRetryPolicy,
    is_unreachable,
    read_capped,
    send_with_retries,
    transient_status_error,
    unreachable_words,
)
from scenemosaic.models._instrument import InstrumentedModel, ModelCall
from scenemosaic.models._limit import FileTokenBucket, LimitedModel, RateLimiter, TokenBucket
from scenemosaic.models._openai import DEFAULT_TIMEOUT_S, OpenAIChatModel, StructuredMode
from scenemosaic.models._parse import MODEL_SPEC_HELP, parse_model
from scenemosaic.models._quality import DEFAULT_UNUSABLE_REPLIES, GivenUp, QualityBreaker, Ticket
from scenemosaic.models._replay import Cassette, ReplayMode, ReplayModel, canonical_request, request_key
from scenemosaic.models._rules import RulesModel
from scenemosaic.models._schema import STRICT_SCHEMA_KEYWORDS, SchemaBounds, extract_json, strict_json_schema
from scenemosaic.models._stack import RunModel, RunModelSettings, open_run_model, server_slots, usage_summary
from scenemosaic.models._tokens import estimate_tokens
from scenemosaic.models._usage import (
    ModelCallLike,
    ModelPrice,
    UsageLimits,
    UsageRecord,
    UsageTracker,
    charged_usage,
)
from scenemosaic.models._wrapper import WrapperModel

__all__ = [
    "DEFAULT_TIMEOUT_S",
    "DEFAULT_UNUSABLE_REPLIES",
    "MODEL_SPEC_HELP",
    "STRICT_SCHEMA_KEYWORDS",
    "AgentFunction",
    "CachedModel",
    "CallClock",
    "Cassette",
    "CircuitBreakerModel",
    "CircuitState",
    "Completion",
    "CompletionModel",
    "DeadlineModel",
    "FileTokenBucket",
    "FunctionModel",
    "GiveUp",
    "GivenUp",
    "HTTPRetryPolicy",
    "ImagePart",
    "InstrumentedModel",
    "LimitedModel",
    "Message",
    "Model",
    "ModelCall",
    "ModelCallLike",
    "ModelPrice",
    "ModelSettings",
    "OpenAIChatModel",
    "QualityBreaker",
    "RateLimiter",
    "ReplayMode",
    "ReplayModel",
    "RequestContext",
    "RulesModel",
    "RunModel",
    "RunModelSettings",
    "SchemaBounds",
    "StructuredMode",
    "TextPart",
    "Ticket",
    "TokenBucket",
    "Usage",
    "UsageLimits",
    "UsageRecord",
    "UsageTracker",
    "WrapperModel",
    "canonical_request",
    "charged_usage",
    "estimate_tokens",
    "extract_json",
    "is_unreachable",
    "open_run_model",
    "parse_model",
    "read_capped",
    "request_key",
    "send_with_retries",
    "server_slots",
    "strict_json_schema",
    "transient_status_error",
    "unreachable_words",
    "usage_summary",
]
