#!/usr/bin/env python3
"""Checks that no panic is reachable from the firmware's tick, link interrupt and idle.

Disassembles the release ELF, builds the static call graph (direct `bl`/`b` branches) and
walks it from each root (the tick's interrupt handler by default). Any reachable
`core::panicking` function is a panic on that path: the check prints the chain that reaches
it and fails.

A call listed in UNREACHABLE is not followed: each is a bounds check the compiler could not
remove though its own code rules it out, with the reason beside it. Anything else that
reaches a panic fails the check.

Usage: no-panic-path.py ELF [ROOT...]    (ROOT defaults to TIM2)
"""
import re
import subprocess
import sys


# (caller, callee) pairs not followed, matched as substrings of the demangled names.
UNREACHABLE = [
    # postcard writes a varint into a stack buffer sized for the type's longest varint
    # (5 bytes for a u32, 3 for a u16) and slices it to the encoded length, which is at most
    # that size by construction (postcard's `varint` module); the slice's check stays.
    ("postcard::ser::serializer::Serializer<F>::try_push_varint_u32", "RangeToInclusive<usize>"),
    ("Serialize for u16>::serialize", "RangeToInclusive<usize>"),
    # defmt-rtt panics when its logger is taken while taken, or released while free; it
    # takes it inside a critical section and every defmt macro pairs the two, so only a
    # fault handler breaking into a log could, and that path has failed already.
    ("_defmt_acquire", "core::panicking"),
    ("_defmt_release", "core::panicking"),
]


def cut(caller, callee):
    return any(a in caller and b in callee for a, b in UNREACHABLE)


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
        if m and current is not None and m.group(1) != current and not cut(current, m.group(1)):
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
