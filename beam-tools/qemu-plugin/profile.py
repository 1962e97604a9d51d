#!/usr/bin/env python3
"""Where a tick's instructions go: the QEMU log of `tick_insns` with profile=on, attributed
to (inlined) functions with the firmware's debug information.

    qemu-system-arm ... -plugin libtick_insns.so,profile=on -d plugin -D insns.log ...
    profile.py FIRMWARE.elf insns.log [--top 30]

Prints instructions per tick by innermost function, then by the chain of callers inside the
tick. Needs arm-none-eabi-addr2line (Debian's binutils-arm-none-eabi).
"""
import argparse
import collections
import re
import subprocess
import sys


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("elf")
    ap.add_argument("log")
    ap.add_argument("--top", type=int, default=25)
    a = ap.parse_args()
    text = open(a.log, encoding="utf-8", errors="replace").read()
    ticks = len(re.findall(r"^tick-insns \d+$", text, re.M))
    # `profile=worst` (`beam pil --insn-profile F --worst-tick`): the counts are one tick's.
    worst = re.search(r"^tick-insns-profile worst (\d+)$", text, re.M)
    if worst:
        ticks = 1
    hits = {int(addr, 16): int(n) for addr, n in re.findall(r"^tick-insns-at (0x[0-9a-f]+) (\d+)$", text, re.M)}
    if not ticks or not hits:
        print(f"{a.log}: no tick counts or no profile (run the plugin with profile=on)", file=sys.stderr)
        return 2
    out = subprocess.run(
        ["arm-none-eabi-addr2line", "-a", "-f", "-i", "-C", "-e", a.elf] + [hex(x) for x in hits],
        capture_output=True, text=True, check=True,
    ).stdout.splitlines()
    chains, current, i = {}, None, 0
    while i < len(out):
        if out[i].startswith("0x"):
            current = int(out[i], 16)
            chains[current] = []
            i += 1
        else:
            chains[current].append(re.sub(r"<[^<>]*>", "", out[i]))
            i += 2  # function, then file:line
    inner, chain = collections.Counter(), collections.Counter()
    for addr, n in hits.items():
        frames = chains.get(addr) or ["?"]
        inner[frames[0]] += n
        chain[" > ".join(f.split("::")[-1] for f in reversed(frames[:4]))] += n
    total = sum(hits.values())
    if worst:
        print(f"the worst tick: {total} instructions (the plugin counted {worst.group(1)})")
    else:
        print(f"{ticks} ticks, {total / ticks:.1f} instructions per tick")
    for title, table in (("innermost function", inner), ("call chain (outermost first)", chain)):
        print(f"\nper tick  {title}")
        for name, n in table.most_common(a.top):
            print(f"{n / ticks:8.1f}  {name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
