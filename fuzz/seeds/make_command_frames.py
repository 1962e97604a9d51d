#!/usr/bin/env python3
"""Writes seed frames for the command fuzz target (beam_wire::command::Request) with the
independent encoder of make_pil_frames.py. Run from fuzz/: python3 seeds/make_command_frames.py

Postcard: a struct is its fields in order, an enum its variant index (varint) then the
variant's fields, an Option a 0/1 tag then the value, a Vec its length (varint) then the
items, u16 a varint, f32 four little-endian bytes."""
import struct

from make_pil_frames import frame, varint


def f32(x):
    return struct.pack("<f", x)


def opt_f32(x):
    return b"\x00" if x is None else b"\x01" + f32(x)


def request(seq, command):
    return varint(seq) + command


def move_to(rad, time_s=None):
    return varint(0) + f32(rad) + opt_f32(time_s)


def move_through(points, time_s=None):
    body = varint(len(points))
    for rad, at in points:
        body += f32(rad) + opt_f32(at)
    return varint(1) + body + opt_f32(time_s)


SEEDS = {
    "move_to": frame(request(1, move_to(0.785, None)), 3),
    "move_to_timed": frame(request(2, move_to(-1.5708, 0.3)), 3),
    "move_through": frame(request(3, move_through([(0.17, None), (-0.52, None)])), 3),
    "move_through_timed": frame(
        request(4, move_through([(0.1 * i, 0.2 * (i + 1)) for i in range(8)])), 3
    ),
    "set_payload": frame(request(5, varint(2) + f32(0.025)), 3),
    "stop_disable_clear_status": frame(request(6, varint(3)), 3)
    + frame(request(7, varint(4)), 3)
    + frame(request(8, varint(5)), 3)
    + frame(request(9, varint(6)), 3),
    "stream": frame(request(10, varint(7) + varint(10)), 3),
}

if __name__ == "__main__":
    import os

    os.makedirs("seeds/command", exist_ok=True)
    for name, data in SEEDS.items():
        with open(f"seeds/command/{name}", "wb") as f:
            f.write(data)
