"""``psmat view`` / :class:`psmat.live.LiveView`, headless (Agg), against the pty twin."""

from __future__ import annotations

import re
import threading
import time

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from psmat import cli  # noqa: E402
from psmat.acquire import DeviceDisconnected, FrameBatch, open_device  # noqa: E402
from psmat.live import LiveView, run_view  # noqa: E402
from psmat.twin import PsmSource, SerialTwin  # noqa: E402


def _drive(view: LiveView, received: int, processed: int, timeout_s: float = 60.0) -> None:
    """Update and draw until the view received and processed that many frames (hang guard: fail).

    At least 3 rounds: the status line is written by update, so the last one has seen the 2
    draws that a display rate needs (a slow first draw on a loaded machine once left it 1).
    """
    deadline = time.monotonic() + timeout_s
    while view.received < received or view.processed < processed or view.draws < 3:
        if time.monotonic() > deadline:
            pytest.fail(f"{view.received} frames received, {view.processed} processed within {timeout_s:g} s")
        view.update(timeout=0.05)
        view.draw()


def test_live_view_on_the_twin_shows_the_mat() -> None:
    shape = (12, 16)  # not square: catches transposed images
    twin = SerialTwin("psm", 100, "v2", shape=shape, scene="sway").start()
    dev = open_device(twin.port, "psm", "v2", shape)
    try:
        dev.start()
        view = LiveView(dev)
        _drive(view, received=120, processed=50)
        # images: the mat's shape, in the arrays and in the artists
        assert view.G.shape == shape and view.pressure_kpa.shape == shape
        assert view.im_raw.get_array().shape == shape and view.im_p.get_array().shape == shape
        # CoP trace: points within the last 10 s, on the mat (cm)
        t, c = view.cop_t, view.cop_cm
        assert len(t) >= 50 and c.shape == (len(t), 2)
        assert np.all(np.diff(t) > 0) and t[-1] - t[0] <= view.history_s
        assert np.all(np.isfinite(c))
        assert np.all((c[:, 0] >= 0) & (c[:, 0] <= (shape[1] - 1) * 2.0))
        assert np.all((c[:, 1] >= 0) & (c[:, 1] <= (shape[0] - 1) * 2.0))
        x, _ = view.line_x.get_data()
        assert len(x) == len(t) and x[-1] == 0.0
        # pressure is zero (up to noise) where the twin puts no load, present where it does
        scene = twin.source.scene.pressure_psi
        T = scene.shape[0]
        assert view.last_seq >= 0
        loaded = np.any(scene[[(view.last_seq + d) % T for d in range(-2, 3)]] > 0, axis=0)
        p = view.pressure_kpa
        assert np.all(np.isfinite(p)) and p.max() > 10.0  # a standing person: tens of kPa
        assert p[~loaded].max() <= 0.05 * p.max()
        assert p[loaded].sum() >= 0.97 * p.sum()
        # raw G shows the crosstalk: non-zero off the load too (that is what IECM removes)
        assert view.G[~loaded].max() > 0
        # status line: port, rates, counters
        s = view.status_text
        assert twin.port in s and "received" in s and "invalid 0" in s and "lost 0" in s
        frames = int(re.search(r"frames (\d+)", s).group(1))
        assert frames == view.received >= 120
        assert re.search(r"received [\d.]+ frames/s", s) and re.search(r"processed [\d.]+ frames/s", s)
        assert re.search(r"display [\d.]+ fps", s)
    finally:
        dev.close()
        twin.stop()


class _FakeDevice:
    """Frames of the twin's physics, handed out in fixed batches (deterministic, no pty)."""

    def __init__(self, shape: tuple[int, int], batches: int, per_batch: int) -> None:
        self.shape = shape
        self.port = "fake"
        self.description = {"rate": 100}
        src = PsmSource.named("quiet", 100.0, shape)
        self._frames = np.stack([src.next() for _ in range(batches * per_batch)])
        self._per, self._k = per_batch, 0
        self.stats = type("S", (), {"frames": 0, "invalid": 0, "dropped_wire": 0, "dropped_buffer": 0})()

    def read(self, n: int | None = None, timeout_s: float | None = None) -> FrameBatch:
        if self._k >= len(self._frames):
            raise DeviceDisconnected(self.port, "end of the fake stream")
        f = self._frames[self._k:self._k + self._per]
        seq = np.arange(self._k, self._k + len(f))
        self._k += len(f)
        self.stats.frames += len(f)
        return FrameBatch(f, np.full(len(f), time.time()), np.ones(len(f), bool), seq, seq * 10_000)


def test_decimate_and_no_iecm() -> None:
    dev = _FakeDevice((16, 16), batches=4, per_batch=20)
    view = LiveView(dev, decimate=5, iecm=False)
    for _ in range(4):
        assert view.update()
    assert view.received == 80
    assert view.processed == 16  # every 5th frame
    assert np.allclose(np.diff(view.cop_t), 0.05)  # 5 frames of 10 ms apart
    assert view.im_p is None and np.all(np.isnan(view.pressure_kpa))
    assert len(view.fig.axes) == 3  # raw image, its colorbar, CoP
    assert "1 in 5 frames" in view.status_text and "raw only" in view.status_text
    with pytest.raises(DeviceDisconnected):
        view.update()
    with pytest.raises(ValueError):
        LiveView(dev, decimate=0)


def test_rates_are_counts_over_the_last_window() -> None:
    from psmat.live.view import SlidingRate

    r = SlidingRate(window_s=2.0)
    r.add(0.0, 0)
    assert np.isnan(r.value)  # one sample: no rate yet
    r.add(0.5, 50)
    r.add(1.0, 100)
    assert r.value == 100.0  # 100 frames in 1 s
    r.add(3.0, 120)  # samples more than the window before the newest are dropped: (1 s, 100) is the oldest
    assert r.value == 10.0  # (120 - 100) / (3 - 1)


def test_cli_simulate_writes_a_screenshot(tmp_path, monkeypatch, capsys) -> None:
    monkeypatch.setenv("MPLBACKEND", "Agg")
    png = tmp_path / "out.png"
    assert cli.main(["view", "--simulate", "--seconds", "2", "--save", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    img = matplotlib.image.imread(png)
    assert img.shape[0] > 300 and img.shape[1] > 900
    assert img[..., :3].std() > 0.05  # not a blank canvas
    out = capsys.readouterr().out
    counts = re.search(r"2 s elapsed; (\d+) frames received, (\d+) processed, 0 invalid", out)
    assert counts and int(counts.group(1)) >= int(counts.group(2)) > 0


def test_a_host_still_reopening_a_vanished_twin_cannot_reach_the_views_twin(tmp_path, monkeypatch, capsys) -> None:
    """A former flake: the view reported its pty disconnected after a few frames.

    The system hands a freed pty number to the next pty at once. A host that keeps re-opening a
    vanished twin's port (``reconnect=True``, or another process) then reached the view's new twin,
    and two hosts on one pty tear each other's stream apart: pyserial flushes the input when it
    opens, a read after ``select`` finds the other host took the bytes, and the view's reader
    takes the port for gone ("readiness to read but returned no data").
    """
    monkeypatch.setenv("MPLBACKEND", "Agg")
    old = SerialTwin("psm", 100, "v2", scene="quiet").start()
    stale = open_device(old.port, reconnect=True, reconnect_attempts=None, reconnect_delay_s=0.01,
                        reconnect_max_delay_s=0.02)
    try:
        stale.start()
        old.disconnect()
        png = tmp_path / "view.png"
        rc = cli.main(["view", "--simulate", "--scene", "quiet", "--seconds", "2", "--save", str(png)])
        reconnects = stale.stats.reconnects
    finally:
        stale.close()
        old.stop()
    captured = capsys.readouterr()
    assert "DISCONNECTED" not in captured.err and rc == 0
    assert reconnects == 0  # the stale host never found a port to re-open
    assert int(re.search(r"(\d+) frames received", captured.out).group(1)) > 0


def test_vanished_port_ends_the_view_with_a_message(tmp_path, monkeypatch, capsys) -> None:
    monkeypatch.setenv("MPLBACKEND", "Agg")
    twin = SerialTwin("psm", 100, "v2").start()
    timer = threading.Timer(1.0, twin.disconnect)
    timer.start()
    png = tmp_path / "gone.png"
    try:
        rc = cli.main(["view", twin.port, "--seconds", "30", "--save", str(png)])
    finally:
        timer.cancel()
        twin.stop()
    assert rc == 3  # ended by the disconnect, not by --seconds (that is status 0)
    err = capsys.readouterr().err
    assert "DISCONNECTED" in err and twin.port in err
    assert png.is_file()


def test_run_view_returns_after_seconds_and_closes() -> None:
    dev = _FakeDevice((16, 16), batches=1000, per_batch=2)
    view = LiveView(dev, iecm=False)
    closed = []
    res = run_view(view, seconds=0.5, interval_s=0.01, interactive=False, on_close=lambda: closed.append(1))
    assert res.status == 0 and res.reason == "seconds" and closed == [1]
    assert res.updates == view.updates >= 1 and view.received == 2 * res.updates  # one batch of 2 per update


def test_cli_needs_a_port_or_simulate(capsys) -> None:
    assert cli.main(["view"]) == 1  # a bad command line is status 1, as in every command
    assert "PORT or --simulate" in capsys.readouterr().err
    assert cli.main(["view", "/dev/psmat-no-such-port", "--seconds", "1", "--save", "x.png"]) == 1
    assert "cannot read a mat" in capsys.readouterr().err
