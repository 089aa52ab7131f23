"""Help for people: every ``psmat`` command's ``--help`` (nested ones and each benchmark
included, found by the command line's own discovery) exits 0, is plain text without
reStructuredText markup, gives every option a help text and shows every default; ``psmat
--version``; the study report and the posture figures spell out their abbreviations where they
first appear, with the meanings the thesis gives them (its list of acronyms, Tables 3.2, 3.4,
4.3, eq. 3.1).
"""

from __future__ import annotations

import argparse
import importlib
import math
import pkgutil
import re
import subprocess
import sys

import pytest

import psmat
import psmat.experiments
from psmat.bench.__main__ import BENCHMARKS, benchmark_parser
from psmat.experiments.__main__ import EXPERIMENTS
from psmat.experiments.__main__ import main as experiments_main
from psmat.cli import build_parser, main, subparsers
from psmat.study import write_results
from psmat.study import COLUMNS

RST = re.compile(r"``|:[a-z]+:`|`_\b")  # ``literal``, :role:`x`, `link`_
#: options with a unit, by destination: the unit the help must name
UNITS = {"seconds": ("s",), "duration": ("s",), "fault_seconds": ("s",), "min_time": ("s",), "budget": ("s",),
         "interval": ("s",), "calibration_s": ("s",), "rate": ("Hz", "frames/s"), "g_rest": ("S",),
         "noise_mv": ("mV",)}


def _tree(parser: argparse.ArgumentParser, path: tuple[str, ...] = ()):
    yield path, parser
    for name, sub in subparsers(parser).items():
        yield from _tree(sub, path + (name,))


COMMANDS = [path for path, _ in _tree(build_parser())]


def _help(argv: list[str], capsys, call=main) -> str:
    with pytest.raises(SystemExit) as stop:
        call(argv)
    assert stop.value.code == 0
    out, err = capsys.readouterr()
    assert err == ""
    return out


def _entries(text: str) -> dict[str, str]:
    """The help text of each argument in an argparse help screen, by its first option string (or
    its name for a positional): what follows the invocation, continuation lines joined."""
    entries: dict[str, str] = {}
    key = None
    lines = text.splitlines()
    # the entries follow the description (whose bullets may be indented too): from argparse's first section
    first = next((k for k, line in enumerate(lines) if line in ("positional arguments:", "options:")), len(lines))
    for line in lines[first:]:
        m = re.match(r"^  (\S.*?)(?:\s{2,}(.*))?$", line)  # an entry starts two spaces in
        if m and not line.startswith("   "):
            key = m.group(1).split(",")[0].split()[0]
            entries[key] = m.group(2) or ""
        elif key is not None and line.startswith("    ") and line.strip():
            entries[key] = (entries[key] + " " + line.strip()).strip()
        elif not line.strip() or not line.startswith(" "):
            key = None
    return entries


def _shown(value) -> list[str]:
    """How a default may read on the command line (worked out here, not by the formatter)."""
    if isinstance(value, float):
        return [f"{value:g}"]
    if isinstance(value, tuple):
        return ["x".join(str(v) for v in value)]
    if isinstance(value, list):
        return [" ".join(map(str, value)), ",".join(map(str, value))]
    return [str(value)]


def _check_screen(text: str, parser: argparse.ArgumentParser) -> None:
    assert not RST.search(text), RST.search(text)
    assert "default: None" not in text and "%(" not in text
    entries = _entries(text)
    for action in parser._actions:
        if isinstance(action, (argparse._HelpAction, argparse._SubParsersAction)):
            continue
        name = action.option_strings[0] if action.option_strings else (action.metavar or action.dest)
        assert name in entries, (name, text)
        shown = entries[name]
        assert shown.strip(), f"{parser.prog} {name} has no help text"
        assert shown.count("(default") <= 1, shown  # not the default written twice
        default = action.default
        flag = action.nargs == 0
        empty = default is None or (isinstance(default, (str, list, tuple)) and len(default) == 0)
        if action.option_strings and not flag and not empty and default is not argparse.SUPPRESS:
            assert "(default: " in shown, (name, shown)
            assert any(f"default: {v}" in shown for v in _shown(default)), (name, default, shown)
        for unit in UNITS.get(action.dest, ()) if action.option_strings else ():
            if re.search(rf"[ (]{re.escape(unit)}[);,]", shown):
                break
        else:
            if action.dest in UNITS and action.option_strings:
                pytest.fail(f"{parser.prog} {name}: no unit ({' or '.join(UNITS[action.dest])}) in {shown!r}")


@pytest.mark.parametrize("path", COMMANDS, ids=[" ".join(p) or "psmat" for p in COMMANDS])
def test_every_command_help_is_plain_and_complete(path, capsys) -> None:
    parser = dict(_tree(build_parser()))[path]
    text = _help([*path, "--help"], capsys)
    assert text.startswith(f"usage: {' '.join(('psmat',) + path)} ")
    _check_screen(text, parser)
    if path:  # a command says what it does: its description, not only the option list
        description = text.split("\n\n")[1]
        assert len(description.split()) >= 5 and not description.startswith(("positional", "options")), text


def test_the_commands_are_all_there(capsys) -> None:
    text = _help(["--help"], capsys)
    for name in ("bench", "calibrate", "demo", "info", "posture", "record", "simulate", "study", "view"):
        assert re.search(rf"^    {name}\b", text, re.M), name
    assert ("study", "run") in COMMANDS and ("posture", "train") in COMMANDS and ("posture", "heldout") in COMMANDS


def test_version(capsys) -> None:
    assert re.fullmatch(r"\d+\.\d+\.\d+\S*", psmat.__version__)
    assert _help(["--version"], capsys) == f"psmat {psmat.__version__}\n"


def test_bench_help_lists_every_benchmark(capsys) -> None:
    text = _help(["bench", "--help"], capsys)
    assert text.startswith("usage: psmat bench ")
    for name in ("iecm", "sensor", "acquire", "study"):
        assert re.search(rf"^\* {name}: ", text, re.M), name
    assert not RST.search(text)


@pytest.mark.parametrize("name", list(BENCHMARKS))
def test_each_benchmark_help_is_plain_and_complete(name, capsys) -> None:
    text = _help(["bench", name, "--help"], capsys)
    assert text.startswith(f"usage: psmat bench {name} ")
    _check_screen(text, benchmark_parser(name, "psmat bench"))


@pytest.mark.parametrize("name", list(EXPERIMENTS))
def test_each_experiment_help_is_plain_and_complete(name, capsys) -> None:
    text = _help([name, "--help"], capsys, experiments_main)
    assert text.startswith(f"usage: python -m psmat.experiments {name} ")
    assert not RST.search(text) and "default: None" not in text
    for key, shown in _entries(text).items():
        assert shown.strip(), (key, text)


def test_bench_without_a_name_is_one_line(capsys) -> None:
    assert main(["bench"]) == 1
    out, err = capsys.readouterr()
    assert out == "" and len(err.strip().splitlines()) == 1 and "iecm" in err


def test_python_m_psmat_bench_help() -> None:
    proc = subprocess.run([sys.executable, "-m", "psmat.bench", "--help"], capture_output=True, text=True,
                          timeout=120, check=False)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("usage: python -m psmat.bench ") and "* iecm: " in proc.stdout
    for name in BENCHMARKS:  # one entry each
        assert len(re.findall(rf"^\* {name}: ", proc.stdout, re.M)) == 1, name


def test_every_benchmark_module_is_behind_python_m_psmat_bench() -> None:
    # a module of psmat.bench that runs as a benchmark (build_parser and main) is one of BENCHMARKS:
    # no benchmark that --help does not list
    import psmat.bench
    from psmat.bench.__main__ import MODULES

    runnable = set()
    for m in pkgutil.iter_modules(psmat.bench.__path__):
        mod = importlib.import_module(f"psmat.bench.{m.name}")
        if not m.name.startswith("_") and hasattr(mod, "main") and hasattr(mod, "build_parser"):
            runnable.add(m.name)
    assert runnable == {MODULES.get(name, name) for name in BENCHMARKS}


def test_python_m_psmat_experiments_help_lists_every_experiment() -> None:
    # every module of psmat.experiments that a user can run is behind the one entry point
    runnable = sorted(m.name for m in pkgutil.iter_modules(psmat.experiments.__path__)
                      if not m.name.startswith("_") and hasattr(importlib.import_module(f"psmat.experiments.{m.name}"),
                                                                "main"))
    assert runnable == sorted(EXPERIMENTS)
    proc = subprocess.run([sys.executable, "-m", "psmat.experiments", "--help"], capture_output=True, text=True,
                          timeout=120, check=False)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("usage: python -m psmat.experiments ")
    for name in EXPERIMENTS:
        assert re.search(rf"^\* {name}: ", proc.stdout, re.M), name
    assert not RST.search(proc.stdout)


# ---------------------------------------------------------------- abbreviations in what psmat writes

#: What each abbreviation must be spelled out as where it first appears (case-insensitive words on
#: that line): the thesis' list of acronyms, Tables 3.2 and 3.4, eq. 3.1; beyond the thesis,
#: what psmat's own variants do.
SPELLED_OUT = {
    "IECM": ("inverse of equivalent conductance method",),
    "FP": ("force platform",),
    "PROP": ("proportional",),
    "PROP-C": ("proportional", "crosstalk"),
    "CHC": ("creep and hysteresis compensation",),
    "SCHC": ("scaled creep and hysteresis compensation",),
    "PROP-8x8": ("proportional", "8x8"),
    "SCHC-8x8": ("scaled creep and hysteresis compensation", "8x8"),
    "SCHC-EQ": ("scaled creep and hysteresis compensation", "equilibrat"),
    "SCHC-DYN": ("scaled creep and hysteresis compensation", "correct"),
    "CoP": ("centre of pressure",),
    "M-L": ("medial-lateral",),
    "A-P": ("anterior-posterior",),
    "SD": ("standard deviation",),
    "σ_ML": ("standard deviation",),
    "Eu": ("euclidean", "eq. 3.1"),
    "BA": ("bland–altman",),
}
STUDY_VARIANTS = ("FP", "PROP", "SCHC", "SCHC-8x8", "SCHC-EQ", "SCHC-DYN")


def _first_line_of(term: str, text: str) -> tuple[int, str]:
    m = re.search(rf"(?<![\w-]){re.escape(term)}(?![\w-])", text)
    assert m, f"{term} not in the report"
    start, end = text.rfind("\n", 0, m.start()) + 1, text.find("\n", m.end())
    return m.start(), text[start:end]


@pytest.fixture(scope="module")
def report(tmp_path_factory) -> str:
    """The report of a small study: two volunteers, one trial, every kind of variant (hand-made rows)."""
    rows = []
    for i, subject in enumerate(("V01", "V02")):
        for k, variant in enumerate(STUDY_VARIANTS):
            row = {c: math.nan for c in COLUMNS}
            row.update(subject=subject, trial="rotation", variant=variant, status="ok", sd_ml_cm=1.0 + i + 0.1 * k,
                       sd_ap_cm=2.0 + i - 0.1 * k, eu_cm=0.0 if variant == "FP" else 0.1 * k,
                       eu_ml_cm=0.0 if variant == "FP" else 0.06 * k, eu_ap_cm=0.0 if variant == "FP" else 0.08 * k)
            rows.append(row)
    out = tmp_path_factory.mktemp("results")
    write_results(out, rows, {}, label="simulation")
    return (out / "report.md").read_text(encoding="utf-8")


@pytest.mark.parametrize("term", list(SPELLED_OUT))
def test_the_report_spells_out_each_abbreviation_where_it_first_appears(term, report) -> None:
    at, line = _first_line_of(term, report)
    assert at < report.index("## Summary"), (term, line)  # before the numbers that use it
    for words in SPELLED_OUT[term]:
        assert words in line.lower(), (term, line)


def test_the_report_spells_out_the_variants_of_the_thesis_tables_too(report) -> None:
    # PROP-C, PROP-8x8 and CHC are not in the study; the tables beside the thesis name them
    for term in ("PROP-C", "PROP-8x8", "CHC"):
        assert re.search(rf"(?<![\w-]){re.escape(term)}(?![\w-])", report.split("## Beside the thesis")[1])
        _, line = _first_line_of(term, report)
        assert line.startswith(f"- **{term}**"), line


def test_posture_splits_are_spelled_out() -> None:
    from psmat.posture.data import SPLIT_NAMES, SPLITS

    # thesis §4.3, Table 4.3: KSI, Keep Subjects In; LSO, Leave Subjects Out
    expected = {"ksi": "KSI (Keep Subjects In", "ksi-leaky": "KSI (Keep Subjects In", "lso": "LSO (Leave Subjects Out"}
    assert set(SPLIT_NAMES) == set(SPLITS)
    for split, start in expected.items():
        assert SPLIT_NAMES[split].startswith(start), SPLIT_NAMES[split]
