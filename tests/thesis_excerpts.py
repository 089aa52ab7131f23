"""Reader of ``tests/data/thesis_excerpts.txt``: verbatim tables and sentences of the thesis.

The file holds the few lines of the thesis (Tables 3.5-3.8 and 4.4, and the sentences of §3.3.1
and §3.3.2 that give percentages and correlations) against which the tests check the numbers that
the package transcribes; ``@@ NAME`` opens a block, ``#`` lines are comments.
"""

from __future__ import annotations

from pathlib import Path

EXCERPTS = Path(__file__).parent / "data" / "thesis_excerpts.txt"


def thesis_excerpt(name: str) -> list[str]:
    """The lines of block ``name`` (e.g. ``"Table 3.5 (§3.3.1)"`` or ``"§3.3.2"``), in order.

    Raises
    ------
    KeyError
        When the file has no block of that name.
    """
    blocks: dict[str, list[str]] = {}
    current: list[str] | None = None
    for line in EXCERPTS.read_text(encoding="utf-8").splitlines():
        if line.startswith("@@ "):
            current = blocks.setdefault(line[3:].strip(), [])
        elif current is not None and line.strip() and not line.startswith("#"):
            current.append(line)
    if name not in blocks:
        raise KeyError(f"no block {name!r} in {EXCERPTS.name} (blocks: {', '.join(blocks)})")
    return blocks[name]
