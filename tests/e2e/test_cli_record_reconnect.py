"""``psmat record`` across a cable pulled (docs/spec.md §5, §13): the board's port vanishes during a
recording and, in the first test, comes back at the same path (as udev's ``/dev/serial/by-id`` link
does). The boards are real ``psmat simulate --protocol csv`` processes on pseudo-terminals behind a
link; the recorder is the command line in a child process, stopped by SIGTERM as a user's Ctrl-C.

Before, the recorder did not re-open the port: the first board's frames were kept and the stream
ended, so a trial whose cable was jostled had to be recorded again.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from psmat.io import load_session
from psmat.process import session_clock

from conftest import child_preexec
from csv_twin import csv_twin
from recording_journal import GUARD_S, journalled, wait_until

pytestmark = pytest.mark.skipif(not hasattr(os, "openpty"), reason="needs pseudo-terminals (POSIX)")


class _Recorder:
    """``psmat record LINK --profile arduino16 -o OUT`` in a child process, its stderr lines gathered as they come."""

    def __init__(self, link: Path, out: Path) -> None:
        self.proc = subprocess.Popen([sys.executable, "-m", "psmat", "record", str(link), "--profile", "arduino16",
                                      "-o", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                     preexec_fn=child_preexec())
        self.lines: list[str] = []
        self._result: tuple[int, str] | None = None
        self._reader = threading.Thread(target=self._gather, daemon=True)
        self._reader.start()

    def _gather(self) -> None:
        for line in self.proc.stderr:
            self.lines.append(line.rstrip("\n"))

    def said(self, text: str) -> list[str]:
        return [x for x in self.lines if text in x]

    def stop(self) -> tuple[int, str]:
        """SIGTERM (a user's Ctrl-C) once; the exit status and stdout."""
        if self._result is None:
            if self.proc.poll() is None:
                self.proc.send_signal(signal.SIGTERM)
            out = self.proc.stdout.read()
            rc = self.proc.wait(GUARD_S)
            self._reader.join(GUARD_S)
            self.proc.stdout.close()
            self.proc.stderr.close()
            self._result = (rc, out)
        return self._result


def _recording_behind_a_link(tmp_path: Path, frames: int) -> tuple[_Recorder, Path, Path, int]:
    """A recorder reading a 50 Hz board through the link ``tmp_path/ttyMAT`` until its journal holds ``frames``;
    the board is then stopped (its pty closed, the link pointing nowhere). The recorder, the link, the
    session file and the frames journalled before the board stopped."""
    link, out = tmp_path / "ttyMAT", tmp_path / "s.h5"
    with csv_twin(rate_hz=50) as port:
        os.symlink(port, link)
        rec = _Recorder(link, out)
        try:
            wait_until(lambda: rec.proc.poll() is not None or journalled(out) >= frames, "the recording took no frame")
            assert rec.proc.poll() is None, rec.lines
        except BaseException:
            rec.stop()
            raise
    try:
        wait_until(lambda: rec.said(f"psmat record: {link} is lost since "),
                   f"no line while the port is lost: {rec.lines}")
    except BaseException:
        rec.stop()
        raise
    return rec, link, out, journalled(out)


def test_a_cable_pulled_and_put_back_is_reopened_and_the_recording_goes_on(tmp_path: Path) -> None:
    rec, link, out, before = _recording_behind_a_link(tmp_path, 20)
    try:
        lost = rec.said(" is lost since ")
        assert len(lost) == 1 and "is the board's USB cable plugged in and the board powered? Frames resume when it " \
                                  "is back" in lost[0], rec.lines
        with csv_twin(rate_hz=50) as second:
            tmp = tmp_path / "new-link"
            os.symlink(second, tmp)
            os.replace(tmp, link)  # the board is back, at the same path
            wait_until(lambda: rec.proc.poll() is not None
                       or (journalled(out) >= before + 20 and rec.said("found again")),
                       f"not re-opened, or nothing recorded after: {rec.lines}")
            rc, summary = rec.stop()
    finally:
        rec.stop()
    assert rc == 0, (rec.lines, summary)
    back = rec.said(f"psmat record: {link} was lost and found again 1 time since it opened, the last at ")
    assert len(back) == 1 and back[0].endswith(" s: a recording running then has no frames for that time"), rec.lines
    said = [x for x in summary.splitlines() if f"{link} was lost and found again 1 time since it opened" in x]
    assert len(said) == 1, summary  # the summary says it too
    s = load_session(out)
    assert s.complete and s.n_frames >= before + 20
    # both boards' frames, one host clock: a time out between them as long as the port was away at least
    t = s.host_time_s
    steps = np.diff(t)
    k = int(np.argmax(steps))
    assert k + 1 >= before >= 20 and s.n_frames - (k + 1) >= 20
    # the first board stopped, a second one started and the port re-opened meanwhile: far longer than a 50 Hz step
    assert steps[k] > 10 * np.median(steps)
    # processed, the time out is one long period, not a stretch of every period (as in the lab's test)
    clock = session_clock(s)
    assert clock.gaps == 1 and np.median(clock.periods_s) < 0.04


def test_a_port_still_lost_when_the_recording_ends_is_said_and_fails_the_command(tmp_path: Path) -> None:
    rec, link, out, before = _recording_behind_a_link(tmp_path, 10)
    rc, summary = rec.stop()
    assert rc == 1, (rec.lines, summary)
    line = [x for x in summary.splitlines() if x.startswith(f"  {link} was lost at ")]
    assert len(line) == 1 and line[0].endswith(" and not found again before the recording ended: the recording has "
                                               "no frames after that"), summary
    s = load_session(out)
    assert s.complete and s.n_frames == before >= 10  # what came before the loss is kept
