#!/usr/bin/env python3
"""Reads a vistaf skin's serial stream in pure Python: no Rust on the robot computer.

Every message on the line is ``0x00 · COBS(postcard(msg) · CRC-32) · 0x00``: COBS removes
the zeros so ``0x00`` delimits frames, CRC-32 (the zlib polynomial, little-endian) rejects
damaged frames, and postcard encodes integers as LEB128 varints (signed ones zigzagged).
This reader decodes ``Hello``, ``Summary``, ``Status`` and ``Clock`` and gives summaries in
SI units with the same field names as ``vistaf-host record``'s JSON lines; other messages
come as ``{"type": "other", "variant": N}``.

    python3 vistaf_serial.py /dev/ttyACM0            # JSON lines, needs pyserial
    python3 vistaf_serial.py --decode capture.bin    # a captured stream, no pyserial

As a library::

    from vistaf_serial import Decoder
    dec = Decoder()
    for msg in dec.feed(port.read(4096)):
        if msg["type"] == "summary":
            print(msg["force_n"], msg["peak_depth_mm"])
"""

import json
import sys
import zlib

PROTOCOL_VERSION = 11
SCHEMA_HASH = 0xC9D8_EA77_8716_206A
# Largest frame on the wire (a full map tile), bytes: anything longer is garbage.
FRAME_MAX = 1700
TEMP_NOT_MEASURED = -32768
FLAG_NAMES = [
    "low_contrast",
    "phase_slope",
    "unwrap_failure",
    "misregistration",
    "over_exposure",
    "temperature_out_of_range",
    "stale_reference",
    "depth_out_of_range",
    "force_out_of_range",
    "temperature_uncertain",
    "depth_unresolved",
    "contact_at_edge",
    "depth_uncertain",
    "faint_contact",
]
# The summary's readings, and which of them each flag says may lie beyond its tolerance
# (vistaf_protocol::Flag::concerns; the interop test holds the two to each other).
READINGS = ["peak_depth", "force", "contact", "contact_temperature", "temperature"]
_GEOMETRY = ["peak_depth", "force", "contact"]
_COLOURS = ["contact_temperature", "temperature"]
FLAG_CONCERNS = {
    "low_contrast": READINGS,
    "phase_slope": _GEOMETRY + ["contact_temperature"],
    "unwrap_failure": _GEOMETRY + ["contact_temperature"],
    "misregistration": READINGS,
    "over_exposure": READINGS,
    "temperature_out_of_range": _COLOURS,
    "stale_reference": READINGS,
    "depth_out_of_range": ["peak_depth"],
    "force_out_of_range": ["force"],
    "temperature_uncertain": _COLOURS,
    "depth_unresolved": ["peak_depth", "contact", "contact_temperature"],
    "contact_at_edge": _GEOMETRY + ["contact_temperature"],
    "depth_uncertain": ["peak_depth"],
    "faint_contact": _GEOMETRY + ["contact_temperature"],
}
RUN_STATES = ["Stopped", "Streaming", "Referencing", "CameraLost"]


class DecodeError(Exception):
    """A frame that is not a message."""


def cobs_decode(data):
    """The bytes a COBS block stands for (without delimiters)."""
    out = bytearray()
    i = 0
    while i < len(data):
        code = data[i]
        end = i + code
        if code == 0 or end > len(data):
            raise DecodeError("bad COBS")
        out += data[i + 1:end]
        i = end
        if code < 0xFF and i < len(data):
            out.append(0)
    return bytes(out)


class Reader:
    """Postcard fields read one after the other."""

    def __init__(self, data):
        self.data = data
        self.at = 0

    def byte(self):
        if self.at >= len(self.data):
            raise DecodeError("message ends early")
        b = self.data[self.at]
        self.at += 1
        return b

    def varint(self, bits):
        value, shift = 0, 0
        while True:
            b = self.byte()
            value |= (b & 0x7F) << shift
            shift += 7
            if not b & 0x80:
                break
            if shift > bits + 7:
                raise DecodeError("varint too long")
        if value >> bits:
            raise DecodeError("varint out of range")
        return value

    def signed(self, bits):
        z = self.varint(bits)
        return (z >> 1) ^ -(z & 1)

    def option(self, read):
        tag = self.byte()
        if tag == 0:
            return None
        if tag == 1:
            return read()
        raise DecodeError("bad option tag")

    def string(self):
        n = self.varint(32)
        if self.at + n > len(self.data):
            raise DecodeError("string ends early")
        s = self.data[self.at:self.at + n]
        self.at += n
        return s.decode("utf-8")


def temperature_c(centi):
    return None if centi == TEMP_NOT_MEASURED else centi / 100.0


def summary(r):
    m = {"type": "summary"}
    m["seq"] = r.varint(32)
    m["capture_us"] = r.varint(64)
    m["latency_us"] = r.varint(32)
    m["force_n"] = r.varint(32) / 1000.0
    m["peak_depth_mm"] = r.varint(32) / 1000.0
    m["contact_area_mm2"] = r.varint(32) / 100.0
    m["volume_mm3"] = r.varint(32) / 1000.0
    centroid = r.option(lambda: (r.signed(16), r.signed(16)))
    m["centroid_mm"] = None if centroid is None else [centroid[0] / 10.0, centroid[1] / 10.0]
    m["temp_min_c"] = temperature_c(r.signed(16))
    m["temp_mean_c"] = temperature_c(r.signed(16))
    m["temp_max_c"] = temperature_c(r.signed(16))
    m["contact_temp_c"] = r.option(lambda: r.signed(16) / 100.0)
    bits = r.varint(16)
    m["flags"] = [name for i, name in enumerate(FLAG_NAMES) if bits >> i & 1]
    m["unknown_flag_bits"] = bits & ~((1 << len(FLAG_NAMES)) - 1)
    # A bit this reader does not know may speak for any reading.
    m["doubted"] = [
        r for r in READINGS
        if m["unknown_flag_bits"] or any(r in FLAG_CONCERNS[f] for f in m["flags"])
    ]
    return m


def hello(r):
    m = {"type": "hello", "protocol_version": r.varint(16), "schema_hash": r.varint(64)}
    if (m["protocol_version"], m["schema_hash"]) != (PROTOCOL_VERSION, SCHEMA_HASH):
        m["compatible"] = False
        return m
    m["compatible"] = True
    m["firmware"] = "%d.%d.%d" % (r.byte(), r.byte(), r.byte())
    m["serial"] = r.string()
    m["frame_width_px"] = r.varint(16)
    m["frame_height_px"] = r.varint(16)
    m["calibration_id"] = "%08x" % r.varint(32)  # as every vistaf tool prints it
    return m


def status(r):
    m = {"type": "status", "uptime_ms": r.varint(64)}
    state = r.varint(32)
    m["state"] = RUN_STATES[state] if state < len(RUN_STATES) else state
    for k in ["max_rate_hz"]:
        m[k] = r.varint(16)
    for k in ["frames_captured", "frames_processed", "frames_dropped", "bad_frames",
              "link_frames_dropped", "reference_age_ms"]:
        m[k] = r.varint(32)
    m["camera_restarts"] = r.varint(16)
    for k in ["latency_p50_us", "latency_p99_us"]:
        m[k] = r.varint(32)
    return m


def clock(r):
    return {"type": "clock", "nonce": r.varint(32), "received_us": r.varint(64),
            "sent_us": r.varint(64)}


DECODERS = {0: hello, 1: summary, 3: status, 7: clock}


def decode_message(payload):
    """One postcard-encoded device message (CRC already checked and removed)."""
    r = Reader(payload)
    variant = r.varint(32)
    read = DECODERS.get(variant)
    if read is None:
        return {"type": "other", "variant": variant}
    m = read(r)
    if m.get("compatible", True) and r.at != len(payload):
        raise DecodeError("trailing bytes")
    return m


def decode_frame(body):
    """One frame between delimiters: the message, or DecodeError."""
    raw = cobs_decode(body)
    if len(raw) < 5:
        raise DecodeError("too short")
    payload, crc = raw[:-4], int.from_bytes(raw[-4:], "little")
    if zlib.crc32(payload) != crc:
        raise DecodeError("CRC mismatch")
    return decode_message(payload)


class Decoder:
    """Takes bytes in any chunking; yields every message; counts every dropped frame."""

    def __init__(self):
        self.buf = bytearray()
        self.dropped = 0
        self.overflow = False

    def feed(self, data):
        for b in data:
            if b != 0:
                if len(self.buf) < FRAME_MAX:
                    self.buf.append(b)
                else:
                    self.overflow = True
                continue
            body, overflow = bytes(self.buf), self.overflow
            self.buf.clear()
            self.overflow = False
            if not body and not overflow:
                continue
            if overflow:
                self.dropped += 1
                continue
            try:
                yield decode_frame(body)
            except (DecodeError, UnicodeDecodeError):
                self.dropped += 1


def main(argv):
    if len(argv) == 3 and argv[1] == "--decode":
        source = sys.stdin.buffer if argv[2] == "-" else open(argv[2], "rb")
        read = lambda: source.read(4096)
    elif len(argv) == 2:
        import serial  # pyserial

        port = serial.Serial(argv[1], 921600, timeout=0.1)
        port.reset_input_buffer()  # what the skin sent before we listened
        read = lambda: port.read(4096)
    else:
        print(__doc__, file=sys.stderr)
        return 2
    dec = Decoder()
    try:
        while True:
            chunk = read()
            if not chunk and len(argv) == 3:
                break
            for msg in dec.feed(chunk):
                print(json.dumps(msg), flush=True)
    except KeyboardInterrupt:
        pass
    print("dropped %d frames" % dec.dropped, file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
