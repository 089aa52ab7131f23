"""Wire protocols of the psmat devices (docs/spec.md §5; byte layouts in docs/protocol.md).

* ``_crc`` - CRC-16/CCITT-FALSE (:func:`crc16`, :func:`crc16_shift`);
* ``_span_crc`` - the CRC of overlapping spans of a stream at a bounded
  cost per byte (:class:`SpanCrc`, what the decoders check candidate packets with);
* ``_v1`` - thesis framing ``FF FF | cells | sum mod 4096`` for the PSM
  and the spine IMUs: :func:`encode_v1`, :func:`decode_v1`, :func:`encode_imu_v1`, ...;
* ``_v2`` - v2 packets (version, seq, t_us, shape, CRC), replies and
  host -> device commands: :func:`encode_v2`, :func:`encode_command`, :class:`Opcode`,
  :func:`parse_identify`, ...;
* ``_decoder`` - incremental decoders fed arbitrary chunks
  (:class:`V1Decoder`, :class:`ImuV1Decoder`, :class:`V2Decoder`) yielding
  :class:`Frame`, :class:`Reply`, :class:`Gap`, at a bounded cost per input byte
  whatever the stream holds (docs/protocol.md, "Decoding cost");
* ``_daq`` - the material DAQ's text lines and ``s``/``f`` commands;
* ``_csv`` - the csv text protocol of do-it-yourself mats (:func:`encode_csv`,
  :class:`CsvDecoder`, :func:`decode_csv`).

The modules are private (``_crc``, ``_v1``, ...); the names they export here are the package's API.
"""

from ._crc import crc16, crc16_shift
from ._csv import CSV_REASONS, CSV_SEPARATORS, CsvDecoder, decode_csv, encode_csv
from ._daq import (DAQ_MAX_COUNT, DAQ_PERIOD_S, DAQ_SENSORS, DAQ_START, DAQ_STOP, DaqLineDecoder, DaqMalformed,
                   DaqSample, encode_daq_command, encode_daq_line, parse_daq_fields, parse_daq_line)
from ._decoder import (Event, Frame, Gap, ImuV1Decoder, Reply, V1Decoder, V2Decoder, decode_imu_v1, decode_v1,
                       decode_v2)
from ._span_crc import SpanCrc
from ._v1 import IMU_SHAPE, INIT, V1_MAX_COUNT, encode_imu_v1, encode_v1, encode_v1_many, v1_frame_size
from ._v2 import (CAL_RESUME, COMMAND_SIZE, HEADER_SIZE, MAX_PAYLOAD, SYNC, VERSION, Opcode, PacketType, Status,
                  cal_hold_arg, decode_command, encode_command, encode_reply, encode_v2, format_identify,
                  parse_identify, v2_frame_size)

__all__ = [
    # crc
    "crc16", "crc16_shift", "SpanCrc",
    # v1
    "INIT", "V1_MAX_COUNT", "IMU_SHAPE", "v1_frame_size", "encode_v1", "encode_v1_many", "decode_v1",
    "encode_imu_v1", "decode_imu_v1",
    # v2
    "SYNC", "VERSION", "HEADER_SIZE", "MAX_PAYLOAD", "COMMAND_SIZE", "CAL_RESUME",
    "PacketType", "Opcode", "Status", "v2_frame_size", "encode_v2", "encode_reply", "encode_command",
    "decode_command", "cal_hold_arg", "parse_identify", "format_identify", "decode_v2",
    # decoders
    "Frame", "Reply", "Gap", "Event", "V1Decoder", "ImuV1Decoder", "V2Decoder",
    # daq
    "DAQ_SENSORS", "DAQ_MAX_COUNT", "DAQ_PERIOD_S", "DAQ_START", "DAQ_STOP", "encode_daq_line",
    "parse_daq_fields", "parse_daq_line", "encode_daq_command", "DaqSample", "DaqMalformed", "DaqLineDecoder",
    # csv
    "CSV_SEPARATORS", "CSV_REASONS", "encode_csv", "CsvDecoder", "decode_csv",
]
