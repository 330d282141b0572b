"""Rate buckets kept in a file are shared: two limiters (two worker processes) on one folder draw
from one budget."""

from __future__ import annotations

import itertools
import subprocess
import sys
from pathlib import Path

from scenemosaic.models import FileTokenBucket


class Clock:
    def __init__(self) -> None:
        self.now = 1_000_000.0
        self.slept: list[float] = []

    def __call__(self) -> float:
        return self.now

    async def sleep(self, seconds: float) -> None:
        self.slept.append(seconds)
        self.now += seconds


async def test_two_buckets_on_one_file_share_the_tokens(tmp_path: Path) -> None:
    clock = Clock()
    a = FileTokenBucket(tmp_path / "m.requests.json", rate_per_s=2.0, capacity=2.0, clock=clock, sleep=clock.sleep)
    b = FileTokenBucket(tmp_path / "m.requests.json", rate_per_s=2.0, capacity=2.0, clock=clock, sleep=clock.sleep)
    await a.acquire(2.0)  # one worker takes the whole burst
    assert clock.slept == []
    await b.acquire(1.0)  # the other waits for the refill: half a second at 2 tokens/s
    assert sum(clock.slept) == 0.5
    b.adjust(1.0)  # a retried request booked afterwards: the level goes into debt
    assert a.level == -1.0


def test_rate_limiters_in_two_processes_keep_one_rate(tmp_path: Path) -> None:
    code = (
        "import asyncio, sys, time\n"
        "from scenemosaic.models import RateLimiter\n"
        "lim = RateLimiter(requests_per_minute=600, shared_dir=sys.argv[1], key='openai:test')\n"
        "async def main():\n"
        "    for _ in range(5):\n"
        "        async with lim.slot():\n"
        "            print(time.time(), flush=True)\n"
        "asyncio.run(main())\n"
    )
    workers = [subprocess.Popen([sys.executable, "-c", code, str(tmp_path)], stdout=subprocess.PIPE, text=True) for _ in range(2)]
    outputs = [w.communicate(timeout=60)[0] for w in workers]
    assert [w.returncode for w in workers] == [0, 0]
    grants = sorted(float(t) for out in outputs for t in out.split())
    assert len(grants) == 10
    # 600 per minute with a burst of one: grants at least 0.1 s apart, whichever process got them
    # (a limiter per process would let the two interleave with no gap); 30 ms allow for the
    # time between a grant and its print under load
    gaps = [b - a for a, b in itertools.pairwise(grants)]
    assert min(gaps) >= 0.1 - 0.03, gaps
    assert (tmp_path / "openai_test.requests.json").is_file()
