"""Progress of a long `gazed eval` on the terminal: what runs, how far it is, the time left.

One tqdm bar on stderr over the whole command, counted in parts: the runs of `eval loop` (five
with `--compare`) or the predictors of `eval estimator --data` (the filters and the baselines).
Each part advances the bar by its share as it goes (a run by the seconds recorded of its
length, a predictor by the steps of the file), and the bar's description names the part and
what it is doing (starting the rig, recording), so the time left covers the rigs' start-ups
too. Like `gazed replay`'s, the bar is silent when stderr is not a terminal or with --json.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterable, Iterator
from types import TracebackType
from typing import TYPE_CHECKING, Any

from tqdm import tqdm

if TYPE_CHECKING:  # not imported at run time: `eval estimator` never opens a bus
    from gazed.bus import Bus
    from gazed.eval.loop_record import Watch

BAR_FORMAT = "{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total} [{elapsed}<{remaining}]"
Steps = Callable[[str, int], Iterable[int]]  # (part's name, count) -> the step indices 0..count-1


def no_progress(_name: str, count: int) -> Iterable[int]:
    """The steps of a part, shown nowhere (what `EvalProgress.steps` replaces)."""
    return range(count)


class EvalProgress:
    """The bar over `parts` parts, cleared by `close` (or on leaving it as a context manager).
    `clock` times the recordings."""

    def __init__(
        self, parts: int, quiet: bool, clock: Callable[[], float] = time.monotonic
    ) -> None:
        self.parts = parts
        self.clock = clock
        self.begun = 0
        self.name = ""
        self.bar = tqdm(
            total=parts,
            bar_format=BAR_FORMAT,
            disable=quiet or not sys.stderr.isatty(),
            leave=False,
        )

    def __enter__(self) -> EvalProgress:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        self.bar.close()

    def begin(self, name: str, doing: str) -> None:
        """The next part begins (the one before is over, early or not)."""
        self._advance_to(self.begun)
        self.begun += 1
        self.name = name
        self.doing(doing)

    def doing(self, what: str) -> None:
        self.bar.set_description_str(f"{self.name} ({self.begun}/{self.parts}): {what}")

    def within(self, fraction: float) -> None:
        """The part begun last is this far (0..1)."""
        self._advance_to(self.begun - 1 + min(max(fraction, 0.0), 1.0))

    def recording(self, seconds: float, *words: str | None, then: Watch | None = None) -> Watch:
        """A run (named by the `words` given) begins: the rig starts. The watch of its recording
        advances the bar by the seconds recorded, and passes on to `then` (the run's own
        watch), whose answer ends the recording."""
        self.begin(" ".join(w for w in words if w), "starting the rig")
        started: float | None = None

        def watch(bus: Bus, messages: dict[str, list[Any]]) -> bool:
            nonlocal started
            now_s = self.clock()
            if started is None:
                started = now_s
                self.doing(f"recording {seconds:g} s")
            self.within((now_s - started) / seconds if seconds > 0 else 1.0)
            return then(bus, messages) if then is not None else False

        return watch

    def steps(self, name: str, count: int) -> Iterator[int]:
        """`range(count)` as the next part."""
        self.begin(name, f"{count} steps")
        for k in range(count):
            yield k
            self.within((k + 1) / count)

    def _advance_to(self, n: float) -> None:
        if n > self.bar.n:
            self.bar.update(n - self.bar.n)
