"""Protocol v2 packets and host->device commands (docs/protocol.md, docs/spec.md §5).

Frame / reply packet (all little-endian)::

    off  size  field
    0    2     sync       0xA5 0x5A
    2    1     version    2
    3    1     type       0x01 PSM counts (uint16) | 0x02 IMU angles (float32) | 0x11 reply
    4    4     seq        uint32 frame number (wraps)
    8    4     t_us       uint32 MCU microseconds at the start of the scan (wraps)
    12   1     rows       R (0 for a reply)
    13   1     cols       C (0 for a reply)
    14   2     length n   payload bytes
    16   n     payload
    16+n 2     crc        CRC-16/CCITT-FALSE over bytes [2, 16+n)

Command (host -> device)::

    0 sync 0xA5 0x5A | 2 version 2 | 3 type 0x10 | 4 opcode | 5 arg uint32 | 9 crc over [2, 9)

A reply's payload is ``opcode (1 byte) | status (1 byte) | ASCII text``.
"""

from __future__ import annotations

import enum
import struct
from typing import Any, Literal, Mapping

from numpy.typing import ArrayLike

from .._checks import as_bytes, float32_frame, int_frame, uint
from ._crc import crc16

__all__ = [
    "SYNC", "VERSION", "HEADER_SIZE", "CRC_SIZE", "MAX_PAYLOAD", "COMMAND_SIZE", "CAL_RESUME",
    "PacketType", "Opcode", "Status",
    "v2_frame_size", "encode_v2", "encode_reply", "encode_command", "decode_command",
    "cal_hold_arg", "parse_identify", "format_identify",
]

#: The two sync bytes that start every v2 packet and command.
SYNC: bytes = b"\xa5\x5a"
#: Protocol version byte.
VERSION: int = 2
#: Bytes before the payload (sync to length).
HEADER_SIZE: int = 16
#: Bytes of the trailing CRC.
CRC_SIZE: int = 2
#: Largest payload a decoder accepts (bytes).
MAX_PAYLOAD: int = 8192
#: Bytes in one command packet.
COMMAND_SIZE: int = 11
#: CAL_HOLD argument that resumes full scans.
CAL_RESUME: int = 0xFFFFFFFF

_HEADER = struct.Struct("<2sBBIIBBH")
_COMMAND = struct.Struct("<2sBBBI")


class PacketType(enum.IntEnum):
    """Type byte (offset 3) of a v2 packet."""

    PSM = 0x01
    IMU = 0x02
    COMMAND = 0x10
    REPLY = 0x11


class Opcode(enum.IntEnum):
    """Command opcodes (argument in brackets)."""

    START = 0x01         #: start streaming frames [0]
    STOP = 0x02          #: stop streaming frames [0]
    SET_RATE = 0x03      #: frames per second [1 ... 1000]
    IDENTIFY = 0x04      #: reply with the device description [0]
    SET_PROTOCOL = 0x05  #: frame format [1 or 2]
    CAL_HOLD = 0x06      #: hold one row-column pair [row << 8 | col], or CAL_RESUME


class Status(enum.IntEnum):
    """Status byte of a reply."""

    OK = 0
    BAD_ARGUMENT = 1
    UNKNOWN_OPCODE = 2


_KINDS = {"psm": PacketType.PSM, "imu": PacketType.IMU}


def v2_frame_size(shape: tuple[int, int], kind: Literal["psm", "imu"] = "psm") -> int:
    """Bytes in one v2 frame packet: ``16 + n + 2`` with ``n = 2*R*C`` (psm) or ``4*R*C`` (imu)."""
    if kind not in _KINDS:
        raise ValueError(f"kind must be 'psm' or 'imu', got {kind!r}")
    r, c = shape
    return HEADER_SIZE + (2 if kind == "psm" else 4) * r * c + CRC_SIZE


def _packet(ptype: int, seq: Any, t_us: Any, rows: int, cols: int, payload: bytes) -> bytes:
    s = uint(seq, "seq", 32, wrap=True)
    t = uint(t_us, "t_us", 32, wrap=True)
    if len(payload) > MAX_PAYLOAD:
        raise ValueError(f"payload of {len(payload)} bytes exceeds the {MAX_PAYLOAD}-byte limit")
    body = _HEADER.pack(SYNC, VERSION, ptype, s, t, rows, cols, len(payload))[2:] + payload
    return SYNC + body + crc16(body).to_bytes(2, "little")


def encode_v2(frame: ArrayLike, seq: int, t_us: int, kind: Literal["psm", "imu"] = "psm") -> bytes:
    """Encode one frame as a v2 packet.

    Parameters
    ----------
    frame : array_like, shape (R, C)
        ``kind="psm"``: integer ADC counts in ``[0, 65535]`` (12-bit in practice), sent as
        uint16. ``kind="imu"``: finite Euler angles in degrees (shape (5, 3) for the spine
        DAQ), sent as float32. ``1 <= R, C <= 255`` and the payload at most 8192 bytes.
    seq : int
        Frame sequence number, >= 0; taken modulo 2**32 (it wraps on the device).
    t_us : int
        Device time of the start of the scan (microseconds), >= 0; taken modulo 2**32.
    kind : {"psm", "imu"}
        Packet type 0x01 or 0x02.

    Returns
    -------
    bytes
        ``16 + n + 2`` bytes (530 for a 16x16 PSM frame).
    """
    if kind == "psm":
        arr = int_frame(frame, "frame", 0xFFFF)
        payload = arr.astype("<u2").tobytes()
    elif kind == "imu":
        arr = float32_frame(frame, "frame")
        payload = arr.astype("<f4").tobytes()
    else:
        raise ValueError(f"kind must be 'psm' or 'imu', got {kind!r}")
    r, c = arr.shape
    if r > 255 or c > 255:
        raise ValueError(f"frame shape {arr.shape} does not fit the one-byte rows/cols fields")
    return _packet(_KINDS[kind], seq, t_us, r, c, payload)


def encode_reply(opcode: int, status: int = Status.OK, text: str | bytes = b"", seq: int = 0, t_us: int = 0) -> bytes:
    """Encode a device reply (type 0x11, rows = cols = 0; what a device or simulator sends).

    Parameters
    ----------
    opcode : int
        The opcode answered, 0 ... 255.
    status : int
        :class:`Status` value, 0 ... 255.
    text : str or bytes
        ASCII text (e.g. the IDENTIFY description).
    seq, t_us : int
        As for a frame (taken modulo 2**32).
    """
    op = uint(opcode, "opcode", 8)
    st = uint(status, "status", 8)
    if isinstance(text, str):
        try:
            raw = text.encode("ascii")
        except UnicodeEncodeError:
            raise ValueError("reply text must be ASCII") from None
    else:
        raw = bytes(as_bytes(text, "text"))
    return _packet(PacketType.REPLY, seq, t_us, 0, 0, bytes((op, st)) + raw)


def encode_command(opcode: int, arg: int = 0) -> bytes:
    """Encode a host -> device command (11 bytes).

    Parameters
    ----------
    opcode : int
        An :class:`Opcode` (any 0 ... 255 is encoded, so that a device's "unknown opcode"
        answer can be exercised).
    arg : int
        uint32 argument, see :class:`Opcode` (e.g. frames per second for SET_RATE,
        :func:`cal_hold_arg` for CAL_HOLD).

    Returns
    -------
    bytes
        ``A5 5A 02 10 opcode arg(4, LE) crc(2, LE)``.
    """
    op = uint(opcode, "opcode", 8)
    a = uint(arg, "arg", 32)
    body = _COMMAND.pack(SYNC, VERSION, PacketType.COMMAND, op, a)
    return body + crc16(body[2:]).to_bytes(2, "little")


def decode_command(packet: bytes | bytearray | memoryview) -> tuple[int, int]:
    """Decode one 11-byte command packet into ``(opcode, arg)``.

    ``opcode`` is an :class:`Opcode` when known, else the plain int. Raises ValueError for a
    packet of the wrong length, sync, version or type, or a failed CRC.
    """
    raw = bytes(as_bytes(packet, "packet"))
    if len(raw) != COMMAND_SIZE:
        raise ValueError(f"a command is {COMMAND_SIZE} bytes, got {len(raw)}")
    sync, ver, typ, op, arg = _COMMAND.unpack_from(raw)
    if sync != SYNC or ver != VERSION or typ != PacketType.COMMAND:
        raise ValueError(f"not a v2 command header: {raw[:4].hex(' ')}")
    crc = int.from_bytes(raw[9:11], "little")
    if crc16(raw[2:9]) != crc:
        raise ValueError(f"command CRC mismatch (got 0x{crc:04X}, expected 0x{crc16(raw[2:9]):04X})")
    try:
        return Opcode(op), arg
    except ValueError:
        return op, arg


def cal_hold_arg(row: int, col: int) -> int:
    """CAL_HOLD argument ``row << 8 | col`` for the held row-column pair (0 ... 255 each)."""
    return (uint(row, "row", 8) << 8) | uint(col, "col", 8)


#: IDENTIFY keys converted to numbers by :func:`parse_identify`; all others stay strings
#: (``serial`` is hexadecimal text, ``fw`` a version).
IDENTIFY_INT_KEYS = frozenset({"rows", "cols", "rate", "proto", "bits"})
IDENTIFY_FLOAT_KEYS = frozenset({"r_o", "v_ref"})


def parse_identify(text: str | bytes) -> dict[str, Any]:
    """Parse an IDENTIFY reply text.

    Parameters
    ----------
    text : str or bytes
        ASCII ``key=value`` pairs separated by single spaces, e.g.
        ``"device=psm fw=0.1.0 rows=16 cols=16 rate=100 proto=2 serial=0000A1B2 r_o=2200
        v_ref=3.3 bits=12"`` (surrounding whitespace and a trailing NUL are tolerated).

    Returns
    -------
    dict
        ``rows``, ``cols``, ``rate`` (frames/s), ``proto``, ``bits`` as int; ``r_o`` (Ω) and
        ``v_ref`` (V) as float; anything else as str.

    Raises
    ------
    ValueError
        A token that is not ``key=value``, an empty or repeated key, non-ASCII text, or a
        numeric key whose value does not parse.
    """
    if isinstance(text, (bytes, bytearray, memoryview)):
        try:
            text = bytes(text).decode("ascii")
        except UnicodeDecodeError:
            raise ValueError("IDENTIFY text must be ASCII") from None
    elif not isinstance(text, str):
        raise TypeError(f"text must be str or bytes, got {type(text).__name__}")
    elif not text.isascii():
        raise ValueError("IDENTIFY text must be ASCII")
    out: dict[str, Any] = {}
    body = text.strip().rstrip("\x00").strip()
    if not body:
        return out
    for token in body.split(" "):
        key, sep, value = token.partition("=")
        if not sep or not key:
            raise ValueError(f"IDENTIFY token {token!r} is not key=value")
        if key in out:
            raise ValueError(f"IDENTIFY key {key!r} repeated")
        try:
            if key in IDENTIFY_INT_KEYS:
                out[key] = int(value, 10)
            elif key in IDENTIFY_FLOAT_KEYS:
                out[key] = float(value)
            else:
                out[key] = value
        except ValueError:
            raise ValueError(f"IDENTIFY value {token!r} is not a number") from None
    return out


def format_identify(info: Mapping[str, Any]) -> str:
    """Format an IDENTIFY text from a mapping (inverse of :func:`parse_identify`).

    Keys and values must be non-empty ASCII without spaces or ``=`` in keys.
    """
    tokens = []
    for key, value in info.items():
        k, v = str(key), str(value)
        if not k or " " in k or "=" in k or " " in v or not (k + v).isascii() or not v:
            raise ValueError(f"cannot format IDENTIFY pair {key!r}={value!r}")
        tokens.append(f"{k}={v}")
    return " ".join(tokens)
