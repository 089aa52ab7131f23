"""Processed products stored in a session file (``/products/NAME``): saving and reading them."""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import ArrayLike

from ..._atomic import replacing
from ._crc import CRC_NAME, chunk_crc
from ._build import write_product
from ._layout import FORMAT_NAME, Product, SessionFormatError, attr_str, journal_path


def save_product(
    path: str | os.PathLike[str], name: str, array: ArrayLike, params: Mapping[str, Any], unit: str
) -> None:
    """Store a processed product (e.g. ``"G"``, ``"g"``, ``"pressure"``, ``"cop"``) in a session file.

    ``params`` (JSON-serialisable: numbers, strings, lists, dicts, NumPy values) records
    how it was made (method, model parameters, calibration serial, …). A product of the
    same name is replaced. The session must be complete (closed, or repaired with
    :func:`psmat.io.repair_session`). See :func:`save_products`: the recording is never
    modified in place.
    """
    save_products(path, {name: (array, params, unit)})


def save_products(path: str | os.PathLike[str],
                  products: Mapping[str, tuple[ArrayLike, Mapping[str, Any], str]]) -> None:
    """Store several products at once: ``{name: (array, params, unit)}`` (see :func:`save_product`).

    The session file is never modified in place: the products are written into a copy beside
    it, which replaces the file only when complete (:func:`psmat._atomic.replacing`), so a
    process killed meanwhile leaves the recording exactly as it was.
    """
    path = Path(path)
    for name in products:
        if not name or "/" in name or name in (".", ".."):
            raise ValueError(f"invalid product name {name!r}")
    if not path.is_file():
        if journal_path(path).exists():
            raise SessionFormatError(
                f"{path}: the recording is still being written or was interrupted "
                f"({journal_path(path).name} exists); close the writer or call repair_session() first"
            )
        raise FileNotFoundError(f"session file not found: {path}")
    with replacing(path) as tmp:
        shutil.copyfile(path, tmp)
        try:
            f = h5py.File(tmp, "r+", libver="latest")  # new objects get checksummed headers too
        except OSError as e:
            raise SessionFormatError(f"{path}: cannot open for writing ({e})") from None
        with f:
            if attr_str(f.attrs.get("format", "")) != FORMAT_NAME:
                raise SessionFormatError(f"{path}: HDF5 file but not a psmat session")
            for name, (array, params, unit) in products.items():
                write_product(f, name, array, params, unit)


def read_products(f: h5py.File, notes: list[str]) -> dict[str, Product]:
    """Every readable ``/products/NAME``; a damaged one (Fletcher-32, CRC-32, attributes) is left out with a note."""
    out: dict[str, Product] = {}
    if "products" not in f:
        return out
    for name in f["products"]:
        try:
            ds = f["products"][name]
            if not isinstance(ds, h5py.Dataset):
                continue
            params = json.loads(attr_str(ds.attrs.get("params_json", "{}")))
            if not isinstance(params, dict):
                raise ValueError("params_json is not a JSON object")
            data = ds[()]  # its storage and dtype were checked with the file's (._storage)
            crc = ds.attrs.get(CRC_NAME)
            if crc is None:
                notes.append(f"product {name!r} carries Fletcher-32 only (written by an older psmat)")
            elif chunk_crc(ds.name, 0, np.asarray(data)) != int(np.asarray(crc).reshape(-1)[0]):
                raise ValueError("CRC-32 mismatch")
            out[name] = Product(data=data, unit=attr_str(ds.attrs.get("unit", "")), params=params,
                                created_utc=attr_str(ds.attrs.get("created_utc", "")))
        except (OSError, KeyError, ValueError, TypeError, IndexError) as e:
            notes.append(f"product {name!r} damaged and left out ({type(e).__name__}: {e})")
    return out
