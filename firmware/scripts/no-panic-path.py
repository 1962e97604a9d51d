#!/usr/bin/env python3
"""Checks that no panic is reachable from the firmware's tick.

Disassembles the release ELF, builds the static call graph (direct `bl`/`b` branches) and
walks it from the tick's interrupt handler. Any reachable `core::panicking` function is a
panic on the tick path: the check prints the chain that reaches it and fails.

Usage: no-panic-path.py ELF [ROOT...]    (ROOT defaults to TIM2)
"""
import re
import subprocess
import sys


def call_graph(elf):
    out = subprocess.run(
        ["arm-none-eabi-objdump", "-d", "-C", "--no-show-raw-insn", elf],
        check=True, capture_output=True, text=True,
    ).stdout
    graph, current = {}, None
    head = re.compile(r"^[0-9a-f]+ <(.*)>:$")
    branch = re.compile(r"\s(?:bl|blx|b|b\.w|b\.n)(?:\w\w)?(?:\.w|\.n)?\s+[0-9a-f]+ <(.*?)(?:\+0x[0-9a-f]+)?>$")
    for line in out.splitlines():
        m = head.match(line)
        if m:
            current = m.group(1)
            graph.setdefault(current, set())
            continue
        m = branch.search(line)
        if m and current is not None and m.group(1) != current:
            graph[current].add(m.group(1))
    return graph


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    elf, roots = sys.argv[1], sys.argv[2:] or ["TIM2"]
    graph = call_graph(elf)
    bad = False
    for root in roots:
        if root not in graph:
            sys.exit(f"{elf}: no function `{root}`")
        parent, todo = {root: None}, [root]
        while todo:
            f = todo.pop()
            for g in graph.get(f, ()):
                if g not in parent:
                    parent[g] = f
                    todo.append(g)
        panics = sorted(f for f in parent if "core::panicking" in f or f == "rust_begin_unwind")
        for p in panics:
            chain, f = [], p
            while f is not None:
                chain.append(f)
                f = parent[f]
            print(f"panic reachable from {root}: " + " <- ".join(chain))
            bad = True
        print(f"{root}: {len(parent)} functions reachable, {len(panics)} panicking")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
