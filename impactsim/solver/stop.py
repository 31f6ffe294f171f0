"""Batch-safe stops: SIGTERM and SIGINT end a run cleanly instead of killing it.

What a batch scheduler sends at its time limit (SIGTERM) and what Ctrl-C sends (SIGINT) are
turned into a request to stop. The time loop looks at the request after every step and, when
set, ends the run the way every stop ends it: a history row and a frame of the last state, a
summary naming the reason, exit code 3 (and a checkpoint, when checkpoints are on:
``checkpoint_on_stop``). During the phases where no step ends for a long time (reading the
case, meshing, building, numba compiling the kernels, the first step) a signal stops the run at
once by raising ``RunStopped``; so does a second signal at any moment (the user insists). While
the last outputs are being written (``finishing``) signals are recorded and nothing is raised,
so no file is left half written.

Hooks, each a few lines for the callers:
    stops = StopSignals.install()    the CLI, first thing (also works without, then run_case
                                     installs it and restores the old handlers at the end)
    stops.urgent = False             once the loop runs: signals wait for the end of the step
    stops.requested                  the reason ("SIGTERM received"), or None
    with stops.finishing(): ...      writing the last frame and the summary
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

SIGNALS = (signal.SIGTERM, signal.SIGINT)
EXIT_STOPPED = 3  # the exit code of a run that stopped before its end time


class RunStopped(BaseException):
    """Raised by the signal handler to stop a phase that has no step boundary (meshing,
    compiling). A BaseException, like KeyboardInterrupt, so that no `except Exception` on the
    way (numba's compiler, meshio, gmsh wrappers) swallows it."""


class StopSignals:
    """The stop request of the process: which signal came, and whether to raise at once."""

    _installed: StopSignals | None = None

    def __init__(self) -> None:
        self.requested: str | None = None
        self.signal: str | None = None
        self.urgent = True
        self._finishing = 0
        self._previous: dict[int, object] = {}

    # --- installation ------------------------------------------------------------------------
    @classmethod
    def install(cls) -> StopSignals:
        """Install the handlers (main thread only; elsewhere a watcher that never fires) and
        return the process's watcher; a second call returns the first one, reset."""
        if cls._installed is not None:
            cls._installed.reset()
            return cls._installed
        stops = cls()
        if threading.current_thread() is threading.main_thread():
            for sig in SIGNALS:
                stops._previous[sig] = signal.signal(sig, stops._handle)
            cls._installed = stops
        return stops

    @classmethod
    def current(cls) -> StopSignals | None:
        return cls._installed

    def uninstall(self) -> None:
        """Put back the handlers that were there before install."""
        for sig, old in self._previous.items():
            signal.signal(sig, old)
        self._previous.clear()
        if StopSignals._installed is self:
            StopSignals._installed = None

    def reset(self) -> None:
        self.requested = self.signal = None
        self.urgent = True
        self._finishing = 0

    # --- the handler -------------------------------------------------------------------------
    def _handle(self, signum: int, frame) -> None:
        name = signal.Signals(signum).name
        first = self.requested is None
        if first:
            self.signal = name
            self.requested = f"{name} received" + (
                " (Ctrl-C)" if signum == signal.SIGINT else "")
        if self._finishing:
            return
        if self.urgent or not first:
            raise RunStopped(self.requested)

    def raise_if_requested(self) -> None:
        """From here on signals are urgent; one that came while they were not raises now."""
        self.urgent = True
        if self.requested is not None:
            raise RunStopped(self.requested)

    @contextmanager
    def finishing(self) -> Iterator[None]:
        """Signals are recorded, never raised, inside this block (the last outputs)."""
        self._finishing += 1
        try:
            yield
        finally:
            self._finishing -= 1


@contextmanager
def watching() -> Iterator[StopSignals]:
    """The process's installed watcher, or one installed for the block and removed after."""
    found = StopSignals.current()
    if found is not None:
        yield found
        return
    stops = StopSignals.install()
    try:
        yield stops
    finally:
        stops.uninstall()


def checkpoint_on_stop(sim, directory, case) -> str | None:
    """A run that stops writes a checkpoint when checkpoints are on (``[output]
    checkpoint_every``), so that ``impactsim run --resume`` continues it. Returns the path
    written, or None. Called inside ``finishing()`` so a signal cannot tear the checkpoint."""
    if sim is None or not getattr(case.output, "checkpoint_every", 0):
        return None
    from impactsim.solver.checkpoint import write_checkpoint

    return str(write_checkpoint(sim, directory))


def stopped_early(case, out_dir, err: BaseException, stops: StopSignals) -> str:
    """A stop before run_case had started (importing the solver): write summary.json with the
    reason into the run's folder when the case is known. Returns the reason."""
    from pathlib import Path

    reason = f"{err} before the run started"
    if case is None:
        return reason + " (case not read yet: nothing written)"
    from impactsim.output.summary import write_summary

    out = Path(out_dir) if out_dir else (case.output.directory or Path("out") / case.run.name)
    with stops.finishing():
        try:
            out.mkdir(parents=True, exist_ok=True)
            write_summary(out / "summary.json", {
                "case": case.run.name, "steps": 0, "time": 0.0, "stopped": reason,
                "stop": {"reason": reason, "kind": "signal", "signal": stops.signal}})
        except OSError:
            pass
    return reason
