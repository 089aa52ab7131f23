"""The suite's own children end with it: a test process killed outright (``kill -9``) takes the
``psmat lab``, ``psmat simulate`` and other processes it started with ``conftest.child_preexec`` along."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import psutil
import pytest

from conftest import child_preexec
from hang_guard import HANG_GUARD_S

TESTS = Path(__file__).resolve().parents[1]

#: a stand-in for a test process: starts a child the way the tests do, prints its pid, waits
PARENT = textwrap.dedent("""
    import subprocess, sys, time
    sys.path.insert(0, sys.argv[1])
    from conftest import child_preexec
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"], preexec_fn=child_preexec())
    print(child.pid, flush=True)
    time.sleep(600)
""")


def _alive(proc: psutil.Process) -> bool:
    try:
        return proc.status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")
def test_a_child_ends_when_the_test_process_is_killed() -> None:
    parent = subprocess.Popen([sys.executable, "-c", PARENT, str(TESTS)], stdout=subprocess.PIPE, text=True)
    child = None
    try:
        child = psutil.Process(int(parent.stdout.readline()))
        assert child.ppid() == parent.pid and child.is_running()
        os.kill(parent.pid, signal.SIGKILL)  # no finally clause runs
        parent.wait(timeout=HANG_GUARD_S)
        # the kernel sent the child SIGTERM: it is gone, or a zombie where its new parent does not reap it
        deadline = time.monotonic() + HANG_GUARD_S
        while _alive(child) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not _alive(child), f"the child {child.pid} outlived the killed test process"
    finally:
        parent.kill()
        parent.wait()
        parent.stdout.close()
        if child is not None and _alive(child):  # (the check failed: not left sleeping)
            child.kill()


def test_the_preexec_restores_the_default_stop_signals() -> None:
    # a child of a shell that ignores SIGINT (a background job) sees SIGINT again
    code = ("import signal, sys; print(signal.getsignal(signal.SIGINT) is signal.default_int_handler, "
            "signal.getsignal(signal.SIGHUP) == signal.SIG_DFL)")
    old = signal.signal(signal.SIGINT, signal.SIG_IGN), signal.signal(signal.SIGHUP, signal.SIG_IGN)
    try:
        plain = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=HANG_GUARD_S)
        fixed = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=HANG_GUARD_S,
                               preexec_fn=child_preexec())
    finally:
        signal.signal(signal.SIGINT, old[0])
        signal.signal(signal.SIGHUP, old[1])
    assert plain.stdout.split() == ["False", "False"]  # inherited: ignored
    assert fixed.stdout.split() == ["True", "True"]
