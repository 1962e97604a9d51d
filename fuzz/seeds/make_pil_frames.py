#!/usr/bin/env python3
"""Writes PIL seed frames with an encoder written apart from the Rust one (zlib's CRC-32,
hand-rolled COBS and postcard varints), so the decoder is tested against the format's
description, not against itself. Run from fuzz/: python3 seeds/make_pil_frames.py"""
import struct
import zlib


def varint(n):
    out = b""
    while True:
        b, n = n & 0x7F, n >> 7
        if n:
            out += bytes([b | 0x80])
        else:
            return out + bytes([b])


def zigzag(n):
    return (n << 1) ^ (n >> 63)


def cobs(data):
    out, block = bytearray(), bytearray()
    for byte in data:
        if byte == 0:
            out += bytes([len(block) + 1]) + block
            block = bytearray()
        else:
            block.append(byte)
            if len(block) == 254:
                out += bytes([255]) + block
                block = bytearray()
    out += bytes([len(block) + 1]) + block
    return bytes(out)


def frame(payload, kind):
    """kind: 1 PIL host to drive, 2 PIL drive to host, 3 command request (beam_wire::Message)."""
    raw = bytes([2 << 4 | kind, len(payload)]) + payload  # version 2 and message kind, payload length
    raw += struct.pack("<I", zlib.crc32(raw))
    return cobs(raw) + b"\x00"


def sensors(seq, enc, code, amp, start):
    return bytes([1]) + varint(seq) + varint(enc) + varint(zigzag(code)) + bytes([amp, start])


SETUP_SMC_0KG = bytes([0, 1]) + struct.pack("<f", 0.0)
STOP = bytes([2])
SEEDS = {
    "setup_sensors_stop": frame(SETUP_SMC_0KG, 1)
    + frame(sensors(0, 0, 1234, 0, 0), 1)
    + frame(sensors(1, 65535, -8388608, 1, 1), 1)
    + frame(STOP, 1),
    "sensors": frame(sensors(123456, 40000, -517, 0, 1), 1),
    "command": frame(bytes([1]) + varint(7) + struct.pack("<fff", 1.5, -1.5707964, 1e-6) + bytes([1, 0]), 2),
    "error_sequence": frame(bytes([2, 1, 2, 5]), 2),
}

if __name__ == "__main__":
    for name, data in SEEDS.items():
        with open(f"seeds/pil_frame/{name}", "wb") as f:
            f.write(data)
