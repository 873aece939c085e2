"""Stopping a run: Ctrl-C (SIGINT) asks it to stop after the cases in progress, a second
Ctrl-C (or SIGTERM) stops it now (a case cut in the middle is not journalled and runs
again on resume)."""

from __future__ import annotations

import os
import signal
import threading

__all__ = ["Stop"]


class Stop:
    """Context manager: installs the SIGINT handler for the block (main thread only);
    ``requested`` turns true at the first Ctrl-C.

    With ``hard=True`` "now" holds inside a long call into C as well (a kernel launch of
    10^8 samples ran for minutes through two Ctrl-C and a SIGTERM): Python runs its signal
    handlers only between bytecodes, so a watchdog thread reads the signals from the
    interpreter's wakeup file descriptor and, when the main thread has not left the block
    within `grace` seconds of the second one, ends the process (exit 130; the finished cases
    are journalled already). That needs the call to release the GIL, as Warp's launches
    do. ``rsmbench run`` sets it; a notebook or a test that calls ``run_suite`` does not,
    so two interrupts never end its process.
    """

    GRACE = 1.0
    CLUSTER_GRACE = 10.0
    """The grace of a run on a Dask cluster: its main thread, waiting in Python, heeds the
    second signal at once, then cancels its cases on the cluster over the network (one
    second could cut that short and leave them running there)."""

    def __init__(self, hard: bool = False, grace: float = GRACE):
        self.requested = False
        self.hard = hard
        self.grace = grace
        self._previous = None
        self._wakeup: tuple[int, int] | None = None
        self._old_fd = -1
        self._done = threading.Event()

    def __enter__(self) -> Stop:
        if threading.current_thread() is not threading.main_thread():
            return self
        self._previous = signal.signal(signal.SIGINT, self._handle)
        if self.hard:
            r, w = os.pipe()
            os.set_blocking(w, False)
            try:
                self._old_fd = signal.set_wakeup_fd(w, warn_on_full_buffer=False)
            except ValueError:  # (not the main interpreter)
                os.close(r)
                os.close(w)
            else:
                self._wakeup = (r, w)
                threading.Thread(target=self._watch, args=(r,), daemon=True).start()
        return self

    def __exit__(self, *exc) -> None:
        self._done.set()
        try:
            if self._wakeup is not None:
                signal.set_wakeup_fd(self._old_fd)
                os.close(self._wakeup[1])  # the watchdog's read ends: it returns
                self._wakeup = None
        finally:
            if self._previous is not None:
                signal.signal(signal.SIGINT, self._previous)

    def _handle(self, signum, frame) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True
        # os.write, not print: the handler may interrupt a print to stderr
        os.write(
            2,
            b"\nrsmbench: stopping after the case(s) in progress; Ctrl-C again to stop now.\n",
        )

    def _watch(self, r: int) -> None:
        seen = 0
        try:
            while True:
                got = os.read(r, 64)
                if not got:  # the run left the block
                    return
                seen += sum(b in (signal.SIGINT, signal.SIGTERM) for b in got)
                if seen >= 2 and not self._done.wait(self.grace):
                    os.write(
                        2,
                        b"\nrsmbench: stopped now; the finished cases are journalled: run the"
                        b" same command again to resume.\n",
                    )
                    os._exit(130)
        finally:
            os.close(r)
