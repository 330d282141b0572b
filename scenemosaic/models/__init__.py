"""The VLM seam: one abstract ``Model.request`` and everything that implements or wraps it.

Models that answer:

* :class:`RulesModel` (``"rules"``) — each agent's deterministic solver; offline.
* :class:`OpenAIChatModel` (``"openai:<model>[@<base_url>]"``) — any OpenAI-compatible
  Chat Completions server, with retries and schema repair.
* :class:`FunctionModel` — Python callables per agent (tests, scripts).

Wrappers that add behaviour around any model:

* :class:`ReplayModel` — record / replay replies in a JSON cassette.
* :class:`LimitedModel` — shared concurrency and request/token rate limits.
* :class:`InstrumentedModel` — a :class:`ModelCall` record per request.
* :class:`SolverFallbackModel` — the asking agent's rule solver answers when the model keeps failing.

:func:`parse_model` builds any of these from a string.
"""

from scenemosaic.models._base import ImagePart, Message, Model, ModelSettings, RequestContext, TextPart, Usage
from scenemosaic.models._completion import Completion, CompletionModel
from scenemosaic.models._fallback import FallbackRecord, SolverFallbackModel
from scenemosaic.models._function import AgentFunction, FunctionModel
from scenemosaic.models._instrument import InstrumentedModel, ModelCall
from scenemosaic.models._limit import LimitedModel, RateLimiter, TokenBucket
from scenemosaic.models._openai import OpenAIChatModel, RetryPolicy, StructuredMode
from scenemosaic.models._parse import MODEL_SPEC_HELP, parse_model
from scenemosaic.models._replay import Cassette, ReplayMode, ReplayModel, canonical_request, request_key
from scenemosaic.models._rules import RulesModel
from scenemosaic.models._schema import SchemaBounds, extract_json, strict_json_schema
from scenemosaic.models._wrapper import WrapperModel

__all__ = [
    "MODEL_SPEC_HELP",
    "AgentFunction",
    "Cassette",
    "Completion",
    "CompletionModel",
    "FallbackRecord",
    "FunctionModel",
    "ImagePart",
    "InstrumentedModel",
    "LimitedModel",
    "Message",
    "Model",
    "ModelCall",
    "ModelSettings",
    "OpenAIChatModel",
    "RateLimiter",
    "ReplayMode",
    "ReplayModel",
    "RequestContext",
    "RetryPolicy",
    "RulesModel",
    "SchemaBounds",
    "SolverFallbackModel",
    "StructuredMode",
    "TextPart",
    "TokenBucket",
    "Usage",
    "WrapperModel",
    "canonical_request",
    "extract_json",
    "parse_model",
    "request_key",
    "strict_json_schema",
]
