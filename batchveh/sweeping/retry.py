"""What every executor of a sweep shares: the callbacks `run` is given, and one retry policy.

An executor (`batchveh.sweep.InProcess`, `cluster.RayExecutor`, `gpus.GpuProcesses`) runs a sweep's chunks
with `run(todo, finished, note, phase)`: `finished(chunk, part name, record)` as each part is written,
`note(text)` for the user, `phase(text)` as each phase starts. It returns {chunk: why} for the chunks that
kept failing elsewhere (a Ray worker, a worker process); an error in the sweep's own process stops the sweep.

The retry policy (`Retries`): a chunk that failed on a worker (it raised, or its worker died) goes back into
the queue and runs again, up to `max_attempts` runs in all (MAX_ATTEMPTS); each retry is a note naming why and
which attempt comes next, and a chunk past the last attempt is reported by name with its last reason, while
the other chunks go on. A chunk that never started (handed to a worker that was let go) spends no attempt.
A worker process that died is started again up to MAX_RESTARTS times (Ray's `max_restarts`, or
`GpuProcesses`'s own).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable

MAX_ATTEMPTS = 3  # runs of one chunk before it is reported failed
MAX_RESTARTS = 3  # restarts of one worker after its process died

Finished = Callable[[int, str, dict], None]  # finished(chunk, part name, record): written, for the manifest
Note = Callable[[str], None]  # a line for the user, or a phase's words


def quiet(_: str) -> None:
    """A `note` or `phase` that nobody hears."""


class Retries:
    """One sweep's failed chunks: how often each has failed (`attempts`), and those given up (`failed`,
    {chunk: why}). `note` hears each retry; it may be replaced (an executor is given its `note` in `run`)."""

    def __init__(self, note: Note = quiet, max_attempts: int = MAX_ATTEMPTS):
        self.note, self.max_attempts = note, max_attempts
        self.attempts: Counter[int] = Counter()
        self.failed: dict[int, str] = {}

    def again(self, c: int, why: str) -> bool:
        """Chunk `c` failed (`why`): count the attempt; True where it runs again (said in a note), False where
        it is given up (in `failed`, with its last reason)."""
        self.attempts[c] += 1
        if self.attempts[c] < self.max_attempts:
            self.note(f"chunk {c}: {why}; it runs again (attempt {self.attempts[c] + 1} of {self.max_attempts})")
            return True
        self.failed[c] = f"failed {self.attempts[c]} times, last: {why}"
        return False

    def tried(self, c: int) -> bool:
        """Whether chunk `c` has failed before."""
        return self.attempts[c] > 0
