"""Models-layer benchmark: how long ``extract_json`` takes on large and hostile replies.

``extract_json`` must stay linear in the reply's length: a 2 MB reply of ``{`` characters
once froze the process for more than ten minutes. Each figure is the best of ``--repeats``
runs (seconds):

* ``extract_json_2mb_braces_s`` — 2 MB of ``{``, refused;
* ``extract_json_4mb_braces_s`` — 4 MB of ``{``, refused (twice the 2 MB figure when linear);
* ``extract_json_2mb_open_strings_s`` — 2 MB of ``{"``, refused;
* ``extract_json_2mb_small_spans_s`` — 2 MB of ``{x}``, refused (many broken candidates);
* ``extract_json_1mb_valid_s`` — a 1 MB JSON object, the whole reply;
* ``extract_json_1mb_in_prose_s`` — the same object after a paragraph of prose, no fence
  (found by the brace scan);
* ``validate_2mb_braces_s`` — ``CompletionModel.request`` refusing the 2 MB ``{`` reply
  (parsing in a worker thread, excerpt for the error).

Run: ``.venv/bin/python benchmarks/models.py [--repeats 5]``. The last line is one JSON object.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import time
from collections.abc import Callable
from typing import Any

from pydantic import BaseModel

from scenemosaic.exceptions import OutputValidationError
from scenemosaic.models import FunctionModel, extract_json


class _Answer(BaseModel):
    value: int


def _best(fn: Callable[[], Any], repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        started = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - started)
    return best


def _refused(text: str) -> Callable[[], None]:
    def run() -> None:
        try:
            extract_json(text)
        except ValueError:
            return
        raise AssertionError("a hostile reply was accepted")

    return run


def _found(text: str, expected: Any) -> Callable[[], None]:
    def run() -> None:
        assert extract_json(text) == expected

    return run


def _validate(text: str) -> Callable[[], None]:
    model = FunctionModel(lambda messages, context: text)

    def run() -> None:
        try:
            asyncio.run(model.request([], _Answer))
        except OutputValidationError:
            return
        raise AssertionError("a hostile reply was accepted")

    return run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    two_mb = 2_000_000
    valid = {
        "items": [
            {"id": f"object_{i}", "pose": [i * 0.5, 1.25, -3.0], "tags": ["a", "b"]} for i in range(14_000)
        ]
    }
    valid_text = json.dumps(valid)
    assert 900_000 < len(valid_text) < 1_100_000, len(valid_text)
    prose = "Let me think about the layout first. " * 20 + "Here is the answer: "
    figures = {
        "extract_json_2mb_braces_s": _best(_refused("{" * two_mb), args.repeats),
        "extract_json_4mb_braces_s": _best(_refused("{" * (2 * two_mb)), args.repeats),
        "extract_json_2mb_open_strings_s": _best(_refused('{"' * (two_mb // 2)), args.repeats),
        "extract_json_2mb_small_spans_s": _best(_refused("{x}" * (two_mb // 3)), args.repeats),
        "extract_json_1mb_valid_s": _best(_found(valid_text, valid), args.repeats),
        "extract_json_1mb_in_prose_s": _best(_found(prose + valid_text + " Done.", valid), args.repeats),
        "validate_2mb_braces_s": _best(_validate("{" * two_mb), args.repeats),
    }
    for name, seconds in figures.items():
        print(f"{name:36s} {seconds:8.4f} s")
    print(json.dumps({k: round(v, 4) for k, v in figures.items()}, sort_keys=True))


if __name__ == "__main__":
    main()
