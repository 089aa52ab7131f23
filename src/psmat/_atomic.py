"""Writing files without losing anyone's data: every file a psmat command writes goes through here.

Two steps, so that a refusal touches nothing:

1. :func:`check_outputs`, before any work: an output that exists (without ``--overwrite``), that
   is one of the command's inputs (the same file, :func:`os.path.samefile`, even with
   ``--overwrite``), that is a folder, whose folder does not exist, or that is named twice, is
   refused with :class:`OutputRefused`, whose message is one line.
2. :func:`replacing` (or :func:`open_atomic`, :func:`write_text_atomic`): the new content is
   written to a hidden temporary file in the output's folder (``.tmp-NAME.XXXX.SUFFIX``, the
   suffix kept so that a writer choosing its format by the file name still can), flushed to
   disk, and moved over the output with :func:`os.replace` only when it is complete. A write
   that fails or is killed leaves the output as it was (and at most a ``.tmp-`` file).

Session files are written the same way by :class:`psmat.io.SessionWriter` (a journal while
recording, ``PATH.partial`` moved over ``PATH`` when it closes); their commands check their
outputs here too. Imports nothing but the standard library.
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import IO, Any

__all__ = ["TMP_PREFIX", "OutputRefused", "check_outputs", "replacing", "open_atomic", "write_text_atomic",
           "same_file", "fsync_dir", "fsync_file", "remove_temporaries", "no_space", "causes"]

#: the name of every temporary file begins so (a study run removes those a killed run left)
TMP_PREFIX = ".tmp-"

PathLike = str | os.PathLike[str]


def no_space(exc: BaseException | None) -> str | None:
    """``"no space left on the disk"`` (or ``"the disk quota is used up"``) when ``exc``, or an error
    that caused it, is the operating system's ENOSPC (EDQUOT); else None. A full disk is the person's
    to fix, in one line, not a traceback (``psmat.cli``)."""
    for e in causes(exc):
        if isinstance(e, OSError) and e.errno in (errno.ENOSPC, getattr(errno, "EDQUOT", errno.ENOSPC)):
            return "no space left on the disk" if e.errno == errno.ENOSPC else "the disk quota is used up"
    return None


def causes(exc: BaseException | None) -> list[BaseException]:
    """``exc`` and the errors that caused it (``__cause__``, else ``__context__``), each once."""
    out: list[BaseException] = []
    while exc is not None and all(exc is not e for e in out):
        out.append(exc)
        exc = exc.__cause__ or exc.__context__
    return out


class OutputRefused(Exception):
    """An output that would destroy an input or an existing file; the message is one line."""


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


#: permissions of a new file, as ``open()`` would give it (read once, at import)
_NEW_FILE_MODE = 0o666 & ~_umask()


def _key(path: Path) -> str:
    return os.path.normcase(os.path.realpath(path))


def same_file(a: PathLike, b: PathLike) -> bool:
    """Whether ``a`` and ``b`` name one file: :func:`os.path.samefile` when both exist (hard and
    symbolic links included), else the same resolved path."""
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return _key(Path(a)) == _key(Path(b))


def check_outputs(outputs: Iterable[PathLike | None], *, inputs: Iterable[PathLike | None] = (),
                  overwrite: bool = False) -> list[Path]:
    """The outputs as paths, or :class:`OutputRefused` for the first that may not be written.

    Parameters
    ----------
    outputs : paths (None entries skipped)
        Every file the command will write.
    inputs : paths (None entries skipped)
        Every file the command reads (a session and its journals, a calibration file, ...);
        an output may never be one of them, ``overwrite`` or not.
    overwrite : bool
        An existing output may be replaced (``--overwrite``).

    Raises
    ------
    OutputRefused
        An output is an input, is named twice, is a folder, has no folder to go in, or exists
        without ``overwrite``. Nothing has been touched.
    """
    outs = [Path(o) for o in outputs if o is not None]
    ins = [Path(i) for i in inputs if i is not None]
    seen: dict[str, Path] = {}
    for out in outs:
        for inp in ins:
            if same_file(out, inp):
                what = "" if str(inp) == str(out) else f" ({inp})"
                raise OutputRefused(f"{out} is one of the inputs{what}: an output never replaces an input; "
                                    "choose another file")
        key = _key(out)
        if key in seen:
            raise OutputRefused(f"{out} is named twice as an output" +
                                ("" if str(seen[key]) == str(out) else f" (also as {seen[key]})"))
        seen[key] = out
        if out.is_dir():
            raise OutputRefused(f"{out} is a folder, not a file")
        folder = out.parent
        if not folder.is_dir():
            raise OutputRefused(f"cannot write {out}: the folder {folder} does not exist")
        if os.path.lexists(out) and not overwrite:
            raise OutputRefused(f"{out} exists; add --overwrite to replace it")
    return outs


def fsync_dir(folder: Path) -> None:
    """Make a rename in ``folder`` durable (best effort: not every system or file system allows it)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def fsync_file(path: Path) -> None:
    """Flush ``path``'s data to disk (Windows needs a handle open for writing to do so)."""
    fd = os.open(path, (os.O_RDWR | getattr(os, "O_BINARY", 0)) if os.name == "nt" else os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


@contextlib.contextmanager
def replacing(path: PathLike, *, overwrite: bool = True) -> Iterator[Path]:
    """A temporary file beside ``path`` to write the new content to, moved over ``path`` when complete.

    Parameters
    ----------
    path : path
        The output. Its folder must exist.
    overwrite : bool
        False: if ``path`` exists when the new content is complete (it appeared meanwhile),
        :class:`OutputRefused` is raised and the new content is kept in the temporary file,
        whose name the message gives.

    Yields
    ------
    Path
        The temporary file (created empty, hidden, in the same folder, same suffix as ``path``).
        When the block ends without an error it is flushed to disk and moved over ``path``
        (:func:`os.replace`: readers see the old file or the new one, never a part); when the
        block raises, it is removed and ``path`` is left as it was.
    """
    path = Path(path)
    folder = path.parent
    fd, name = tempfile.mkstemp(prefix=f"{TMP_PREFIX}{path.name}.", suffix=path.suffix, dir=folder)
    os.close(fd)
    tmp = Path(name)
    keep = False
    try:
        try:  # the replaced file's permissions, else those open() gives a new file (mkstemp's are 0600)
            os.chmod(tmp, stat.S_IMODE(os.stat(path).st_mode))
        except OSError:
            os.chmod(tmp, _NEW_FILE_MODE)
        yield tmp
        fsync_file(tmp)
        if not overwrite and os.path.lexists(path):
            keep = True
            raise OutputRefused(f"{path} appeared while it was being written; the new content is in {tmp}")
        os.replace(tmp, path)
    except BaseException:
        if not keep:
            with contextlib.suppress(OSError):
                tmp.unlink()
        raise
    fsync_dir(folder)


@contextlib.contextmanager
def open_atomic(path: PathLike, mode: str = "w", *, overwrite: bool = True) -> Iterator[IO[Any]]:
    """An open file whose content replaces ``path`` when the block ends without an error (:func:`replacing`).

    ``mode`` is ``"w"`` (text: UTF-8, newlines as written) or ``"wb"``.
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"mode must be 'w' or 'wb', got {mode!r}")
    with replacing(path, overwrite=overwrite) as tmp:
        with open(tmp, mode, **({"encoding": "utf-8", "newline": ""} if mode == "w" else {})) as fh:
            yield fh


def write_text_atomic(path: PathLike, text: str, *, overwrite: bool = True) -> None:
    """``path`` gets ``text`` (UTF-8) whole or keeps what it had."""
    with open_atomic(path, "w", overwrite=overwrite) as fh:
        fh.write(text)


def remove_temporaries(folder: PathLike) -> int:
    """Delete the temporary files (:data:`TMP_PREFIX`) a killed writer left in ``folder``; how many.

    Call it only while no writer uses the folder (a study run holds its lock).
    """
    n = 0
    for p in Path(folder).glob(TMP_PREFIX + "*"):
        p.unlink(missing_ok=True)
        n += 1
    return n
