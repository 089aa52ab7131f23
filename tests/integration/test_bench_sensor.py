"""The sensor-model benchmark's command line: ``python -m psmat.bench sensor``."""

from __future__ import annotations

import json

import pytest

from psmat.bench.sensor import identification_data, main
from psmat.sensor import fit


@pytest.mark.slow
def test_seed_reaches_the_annealers(tmp_path, capsys):
    # regression: the README quoted the 9-parameter annealing over seeds
    # 2, 4 and 6, but `bench sensor` had no --seed: no command printed those figures
    out = tmp_path / "sensor.json"
    assert main(["--quick", "--seed", "2", "--json", str(out)]) == 0
    assert "annealing seed 2" in capsys.readouterr().out
    res = json.loads(out.read_text())
    assert res["seed"] == 2
    row = next(r for r in res["identification"] if r["method"].startswith("anneal C++ reduced"))
    ps, gs = identification_data(quick=True)
    direct = fit(ps, gs, 0.5, method="anneal", seed=2, max_evals=1000)  # the bench's --quick budget
    assert row["sse_n"] == pytest.approx(direct.sse_n, rel=1e-12)


def test_a_negative_seed_is_refused(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--seed", "-1"])
    assert exc.value.code == 2
    assert "--seed must be >= 0" in capsys.readouterr().err
