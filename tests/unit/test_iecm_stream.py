"""The live stream: frames in as they arrive, solutions out in order."""

from __future__ import annotations

import threading

import numpy as np
import pytest

import psmat


def _recording(rng, T=40, shape=(6, 8)):
    base = np.exp(rng.uniform(np.log(1e-5), np.log(1e-2), shape))
    drift = 1 + 0.05 * np.sin(np.linspace(0, 3, T))[:, None, None] * rng.uniform(-1, 1, shape)
    g = base * drift
    return g, psmat.iecm.forward(g)


@pytest.mark.parametrize("threads", [1, 2])
def test_stream_returns_frames_in_order(threads, rng):
    g, G = _recording(rng)
    out = []
    with psmat.iecm.Stream(G.shape[1:], threads=threads, max_pending=8) as s:
        out.extend(s.process(G))
    seqs = [seq for seq, _, _ in out]
    assert seqs == list(range(len(G)))
    sol = np.stack([x for _, x, _ in out])
    np.testing.assert_allclose(sol, g, rtol=1e-7)
    assert all(info.converged for _, _, info in out)
    # warm starts: after the first frame, frames need far fewer iterations than a cold solve
    its = np.array([int(info.iterations) for _, _, info in out])
    _, cold = psmat.iecm.solve(G[len(G) // 2], return_info=True)
    assert np.median(its[1:]) < cold.iterations


def test_stream_producer_and_consumer_threads(rng):
    # push from one thread while another blocks in pop(): pop must not hold the GIL
    g, G = _recording(rng, T=30)
    s = psmat.iecm.Stream(G.shape[1:], threads=2, max_pending=4)
    got = []

    def consume():
        while (r := s.pop(None)) is not None:
            got.append(r)

    c = threading.Thread(target=consume)
    c.start()
    for frame in G:
        s.push(frame)
    s.close()
    c.join(timeout=30)
    assert not c.is_alive()
    assert [seq for seq, _, _ in got] == list(range(30))
    np.testing.assert_allclose(np.stack([x for _, x, _ in got]), g, rtol=1e-7)


def test_process_never_deadlocks_on_a_full_stream(rng):
    # one thread pushing and popping through a tiny queue: process() must pop before it
    # pushes into a full stream (regression: push used to wait forever for a consumer)
    g, G = _recording(rng, T=60, shape=(4, 5))
    for _ in range(20):
        with psmat.iecm.Stream(G.shape[1:], threads=2, max_pending=2) as s:
            out = list(s.process(G))
        assert [seq for seq, _, _ in out] == list(range(60))


def test_push_into_a_full_stream_times_out(rng):
    g, G = _recording(rng, T=3, shape=(4, 4))
    s = psmat.iecm.Stream((4, 4), max_pending=2)
    s.push(G[0])
    s.push(G[1])
    with pytest.raises(TimeoutError, match="full"):
        s.push(G[2], timeout_s=0.05)
    assert s.pop(None)[0] == 0  # popping frees a slot
    assert s.push(G[2], timeout_s=5.0) == 2
    s.close()


def test_stream_rejects_bad_frames_and_push_after_close(rng):
    s = psmat.iecm.Stream((4, 4))
    with pytest.raises(ValueError, match="shape"):
        s.push(np.full((4, 5), 1e-3))
    with pytest.raises(ValueError, match="non-finite"):
        s.push(np.full((4, 4), np.nan))
    s.close()
    with pytest.raises(RuntimeError, match="closed"):
        s.push(np.full((4, 4), 1e-3))
    assert s.pop(0.1) is None


def _noisy_twin_frames(T=50):
    """16x16 G as a mat measures it (1 mV, 12 bits): slower to solve than to push."""
    from psmat.circuit import OPEN
    from psmat.process import open_floor
    from psmat.twin import swaying_feet

    c = psmat.Circuit()
    g = swaying_feet(T, (16, 16), seed=0)
    G, flags = c.conductance(c.counts(psmat.iecm.forward(g), noise_v=1e-3, rng=1), return_flags=True)
    return np.where(flags == OPEN, open_floor(c), G)


def _readme_stream_example() -> str:
    """The README's `with psmat.iecm.Stream(...)` statement, as printed there."""
    from pathlib import Path

    lines = (Path(__file__).resolve().parents[2] / "README.md").read_text().splitlines()
    start = next(k for k, line in enumerate(lines) if line.startswith("with psmat.iecm.Stream("))
    body = [lines[start]]
    for line in lines[start + 1:]:
        if line.strip() and not line.startswith(" "):
            break
        body.append(line)
    return "\n".join(body)


def test_the_readme_stream_example_returns_every_frame():
    # regression: run as written, the example got 0 of 50 noisy frames from
    # ready() (they arrive faster than they are solved) and left the rest unread at exit
    G = _noisy_twin_frames()
    ns = {"psmat": psmat, "np": np, "live_frames": list(G)}
    exec(compile(_readme_stream_example(), "README.md", "exec"), ns)
    assert ns["s"].pending == 0  # every pushed frame was popped by the example's own code
    assert ns["seq"] == len(G) - 1  # the last frame it handled is the last one pushed
    expected = psmat.iecm.solve(G[-1])
    loaded = expected >= 1e-4
    np.testing.assert_allclose(ns["g_frame"][loaded], expected[loaded], rtol=1e-6)


def test_leaving_the_with_block_with_unread_frames_warns():
    G = _noisy_twin_frames(T=20)
    with pytest.warns(RuntimeWarning, match=r"20 frames pushed and never popped.*drain\(\)"):
        with psmat.iecm.Stream((16, 16), threads=2) as s:
            for frame in G:
                s.push(frame)
    assert len(list(s.drain())) == 20  # still there for whoever drains afterwards


def test_leaving_the_with_block_on_an_exception_does_not_warn():
    G = _noisy_twin_frames(T=5)
    with pytest.raises(KeyError):
        with psmat.iecm.Stream((16, 16)) as s:
            s.push(G[0])
            raise KeyError("the caller's own error")
