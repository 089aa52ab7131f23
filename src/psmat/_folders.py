"""A study folder's files as people gather them (docs/spec.md §6): hidden files are no data, a file
whose stem differs only in case is the one meant, and files in subfolders are said, not skipped.

One rule for the balance study (:func:`psmat.study.find_study`), the posture study
(:func:`psmat.posture.data.load_posture_study`) and the lab app's list of sessions.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

__all__ = ["hidden", "data_files", "companion", "nested", "WORKBOOKS", "workbook_hint"]


def hidden(path: Path) -> bool:
    """Whether ``path`` is a hidden file, which is no data: ``._NAME`` is the AppleDouble file a Mac
    writes beside every file it copies to a FAT or exFAT drive (a USB stick), ``.NAME`` a hidden one."""
    return path.name.startswith(".")


def data_files(folder: Path, suffixes: tuple[str, ...]) -> dict[str, list[Path]]:
    """The files of ``folder`` whose suffix is one of ``suffixes`` (any case), hidden ones left out,
    by their stem in lower case (sorted lists; empty when there is no such folder)."""
    found: dict[str, list[Path]] = {}
    for p in sorted(folder.glob("*")):
        if p.suffix.lower() in suffixes and p.is_file() and not hidden(p):
            found.setdefault(p.stem.casefold(), []).append(p)
    return found


def companion(stem: str, found: dict[str, list[Path]], what: str,
              owner: str = "session") -> tuple[Path | None, str | None]:
    """The ``what`` file of ``stem`` among ``found`` (:func:`data_files`): the one of that stem, else
    the one whose stem differs from it only in case (Windows, where a study's files are often
    gathered, does not tell them apart); (None, why) when two or more could be it.

    ``owner`` names what ``stem`` is in that line (a session, a box).
    """
    alike = found.get(stem.casefold(), [])
    same = [p for p in alike if p.stem == stem] or alike
    if len(same) > 1:
        return None, (f"{len(same)} {what} files for {owner} {stem}: {', '.join(p.name for p in same)}; "
                      "which one belongs to it is not known: keep one")
    return (same[0] if same else None), None


def nested(root: Path, folders: Sequence[tuple[str, tuple[str, ...]]]) -> list[str]:
    """One problem line for the files in subfolders of ``root``'s ``folders`` (name, suffixes),
    which are not read: a study's files sit directly in its folders, and nothing is skipped unsaid.
    Hidden files and folders are left out. Empty when there are none."""
    found = []
    for folder, suffixes in folders:
        top = root / folder
        if top.is_dir():
            found += [p.relative_to(root).as_posix() for p in sorted(top.rglob("*"))
                      if p.parent != top and p.suffix.lower() in suffixes and p.is_file()
                      and not any(part.startswith(".") for part in p.relative_to(top).parts)]
    if not found:
        return []
    shown = ", ".join(found[:3]) + (", ..." if len(found) > 3 else "")
    where = [f"{name}/" for name, _ in folders]
    where = ", ".join(where[:-1]) + f" and {where[-1]}" if len(where) > 1 else where[0]
    return [f"{len(found)} file(s) in subfolders are not read ({shown}): a study's files sit directly in "
            f"{where}"]


#: a spreadsheet program's own files, which psmat does not read: a table is saved as CSV for it
WORKBOOKS = (".xlsx", ".xls", ".xlsm", ".ods", ".numbers")


def workbook_hint(folder: Path, stem: str, shown: str = "") -> str:
    """``"forceplate/S01.xlsx is a spreadsheet workbook ...: save it as CSV ..."`` when ``folder`` holds a
    workbook of ``stem`` (any case) where a CSV was looked for, else ``""``; ``shown`` is the folder as the
    line names it (``"forceplate/"``; ``""``: the name alone)."""
    books = data_files(folder, WORKBOOKS).get(stem.casefold(), [])
    if not books:
        return ""
    return (f"{shown}{books[0].name} is a spreadsheet workbook, which psmat does not read: save it as CSV "
            "(File > Save As > CSV) beside it")
