"""The study's lock (``results/.lock``, :func:`psmat.study.study_lock`) between real processes:
a second holder is refused while the first holds it, and a holder that is killed leaves
nothing that blocks the next run."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from psmat.study import study_lock
from conftest import child_preexec

#: a process that takes the lock, says so, and holds it until its standard input closes
HOLDER = textwrap.dedent("""
    import sys
    from pathlib import Path
    from psmat.study import study_lock
    with study_lock(Path(sys.argv[1])):
        print("held", flush=True)
        sys.stdin.read()
    print("released", flush=True)
""")


def _holder(results: Path) -> subprocess.Popen:
    proc = subprocess.Popen([sys.executable, "-c", HOLDER, str(results)], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True, preexec_fn=child_preexec())
    assert proc.stdout.readline().strip() == "held"  # blocks until the lock is taken (or the process died)
    return proc


def test_a_second_holder_is_refused_until_the_first_lets_go(tmp_path) -> None:
    results = tmp_path / "results"
    proc = _holder(results)
    try:
        with pytest.raises(RuntimeError, match="another psmat study run is writing"):
            with study_lock(results):
                pass
        out, _ = proc.communicate("", timeout=60)  # stdin closed: the holder leaves its block
        assert out.strip() == "released" and proc.returncode == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    with study_lock(results):  # free again
        pass


def test_a_killed_holder_does_not_block_the_next_run(tmp_path) -> None:
    results = tmp_path / "results"
    proc = _holder(results)
    proc.kill()  # SIGKILL (POSIX) / TerminateProcess (Windows): no cleanup code runs
    proc.wait(60)
    proc.stdout.close()
    proc.stdin.close()
    assert (results / ".lock").exists()  # the lock file stays behind ...
    with study_lock(results):  # ... and is no lock: the system released the killed holder's
        second = subprocess.run([sys.executable, "-c", HOLDER, str(results)], input="", capture_output=True,
                                text=True, timeout=60)
    assert second.returncode != 0 and "another psmat study run is writing" in second.stderr  # and it excludes again
