"""The lab server's guards (psmat.lab._security): the token check and the data-folder confinement,
on real paths and real symbolic links."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

pytest.importorskip("starlette")

from psmat.lab import PathRefused, confine, is_loopback, new_token, request_token, safe_component, token_matches  # noqa: E402


def test_tokens_are_random_urlsafe_and_long() -> None:
    tokens = {new_token() for _ in range(50)}
    assert len(tokens) == 50
    assert all(len(t) == 43 and t.replace("-", "").replace("_", "").isalnum() for t in tokens)  # 256 bits


def test_the_token_must_match_exactly() -> None:
    tok = new_token()
    assert token_matches(tok, tok)
    for given in (None, "", tok[:-1], tok + "x", tok.upper() if tok.upper() != tok else tok + "A", " " + tok):
        assert not token_matches(tok, given), given
    assert not token_matches("", "")


def test_the_token_comes_from_the_bearer_header_or_the_query() -> None:
    assert request_token(b"token=abc&x=1", None) == "abc"
    assert request_token("x=1&token=a-b_c", None) == "a-b_c"
    assert request_token(b"", "Bearer xyz") == "xyz"
    assert request_token(b"token=q", "bearer h") == "h"   # the header wins
    assert request_token(b"tok=abc", "Basic abc") is None
    assert request_token(b"", None) is None


def test_paths_are_confined_to_the_data_folder(tmp_path: Path) -> None:
    data = tmp_path / "data"
    data.mkdir()
    assert confine(data, "a.h5") == (data / "a.h5").resolve()
    assert confine(data, str(data / "sub" / "b.h5")) == (data / "sub" / "b.h5").resolve()
    assert confine(data, "sub/../c.h5") == (data / "c.h5").resolve()
    for bad in ("../x.h5", "../../etc/passwd", "/etc/passwd", "..", ".", "", "sub/../../x", "a\x00b"):
        with pytest.raises(PathRefused):
            confine(data, bad)
    (tmp_path / "outside.h5").write_bytes(b"")
    os.symlink(tmp_path / "outside.h5", data / "link.h5")
    with pytest.raises(PathRefused):   # a symbolic link out of the folder is outside
        confine(data, "link.h5")
    os.symlink(tmp_path, data / "up")
    with pytest.raises(PathRefused):
        confine(data, "up/outside.h5")


def test_subject_and_trial_become_safe_file_name_components() -> None:
    assert safe_component("P01") == "P01"
    assert safe_component("eyes-open_2") == "eyes-open_2"
    for text in ("../../x", "/etc/y", "a/b\\c", "..", ".hidden", "x\x00y", "é ü"):
        out = safe_component(text)
        assert out and "/" not in out and "\\" not in out and "." not in out and "\x00" not in out, (text, out)
    assert safe_component("../../x") == "x"
    assert safe_component("") == "none" and safe_component("../..") == "none"
    assert len(safe_component("a" * 500)) == 64


def test_loopback_hosts() -> None:
    for host in ("127.0.0.1", "127.8.9.1", "::1", "[::1]", "localhost", "LOCALHOST"):
        assert is_loopback(host), host
    for host in ("0.0.0.0", "192.168.1.4", "::", "example.org", "10.0.0.1"):
        assert not is_loopback(host), host
