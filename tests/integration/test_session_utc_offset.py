"""A session stores its computer's offset from UTC (docs/spec.md §6), so that times read off the wall
during the recording (an experimenter's log) become host times; the events reader turns them so
(psmat.balance.load_events_csv). Real files, a real child process killed before it closes its file."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import h5py
import pytest

from psmat.balance import load_events_csv
from psmat.io import info, load_session, repair_session

EAST_3H = "XYZ-3"  # a POSIX TZ three hours east of UTC
WRITE = ("import numpy as np, os, sys\n"
         "from psmat.io import SessionWriter\n"
         "w = SessionWriter(sys.argv[1], (4, 4), {'rows': 4, 'cols': 4})\n"
         "w.append(np.full((5, 4, 4), 100, np.uint16), 1.7e9 + np.arange(5) * 0.01, np.ones(5, bool))\n"
         "{end}\n")


def _write(path: Path, tz: str, close: bool) -> None:
    code = WRITE.replace("{end}", "w.close()" if close else "os._exit(0)  # killed: the journal alone")
    subprocess.run([sys.executable, "-c", code, str(path)], check=True, env={**os.environ, "TZ": tz}, timeout=120)


def test_the_offset_is_stored_closed_recovered_and_repaired(tmp_path: Path) -> None:
    closed, killed = tmp_path / "closed.h5", tmp_path / "killed.h5"
    _write(closed, EAST_3H, close=True)
    _write(killed, EAST_3H, close=False)
    assert load_session(closed).utc_offset_s == 3 * 3600
    assert "(the recording computer at UTC+03:00)" in info(load_session(closed))
    assert not killed.exists() and load_session(killed).utc_offset_s == 3 * 3600  # from the journal's header
    assert repair_session(killed).utc_offset_s == 3 * 3600 and load_session(killed).complete
    west = tmp_path / "west.h5"
    _write(west, "XYZ+5", close=True)  # five hours west
    assert load_session(west).utc_offset_s == -5 * 3600
    assert "(the recording computer at UTC-05:00)" in info(load_session(west))
    # a file written before psmat stored it: not known, never taken for UTC
    with h5py.File(west, "r+") as f:
        del f.attrs["utc_offset_s"]
    assert load_session(west).utc_offset_s is None


def test_wall_clock_markers_become_host_times(tmp_path: Path) -> None:
    """By hand: 2024-03-01 09:30:00 UTC is 1 709 285 400 s; on a computer an hour east of UTC the wall
    reads 10:30:00 then."""
    near = 1709285400.0
    p = tmp_path / "log.csv"
    p.write_text("time;label\n10:32:15,5;eyes open\n2024-03-01 10:33:00;eyes closed\n2024-03-01T09:34:00Z;end\n"
                 "2024-03-01T11:35:00+02:00;after\n")
    got = load_events_csv(p, utc_offset_s=3600, near_s=near)
    assert got == [(near + 135.5, "eyes open"), (near + 180.0, "eyes closed"), (near + 240.0, "end"),
                   (near + 300.0, "after")]
    # a recording that runs past midnight: a time of day goes to the day that puts it nearest the recording
    p.write_text("time,label\n00:00:30,late\n23:59:30,early\n")
    midnight = 1709251200.0  # 2024-03-01 00:00:00 UTC
    assert load_events_csv(p, utc_offset_s=0, near_s=midnight - 60) == [(midnight + 30, "late"),
                                                                        (midnight - 30, "early")]
    with pytest.raises(ValueError, match=r"line 2: time '00:00:30' is the clock on the wall without its offset from "
                                         r"UTC, and the recording does not store its computer's"):
        load_events_csv(p)
    p.write_text("time,label\n2024-03-01T09:34:00Z,end\n")  # with its offset: exact without the recording
    assert load_events_csv(p) == [(near + 240.0, "end")]
