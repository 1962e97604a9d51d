#!/usr/bin/env python3
"""The boards' flash and static RAM as the docs quote them.

Measures each board CI built (`arm-none-eabi-size`: flash is text + data, static RAM data +
bss) and checks that every doc that quotes the figure quotes the measured one, written as
the docs write bytes ("38 760 B"). A change that moves a board's size fails CI until the docs
say so: the figures cannot drift from what the build makes.

Usage: check-doc-figures.py SMC_BOARD_ELF SMC_MODAL_BOARD_ELF SMC_MODAL_EXACT_BOARD_ELF

(the third: the smc-modal board of a table that asks for exact moves, `cargo fw --features
exact`.)
"""
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]

# Which doc quotes which figure of which board.
QUOTES = {
    "README.md": [("smc", "flash"), ("smc-modal", "flash")],
    "docs/results.md": [
        ("smc", "flash"),
        ("smc", "ram"),
        ("smc-modal", "flash"),
        ("smc-modal", "ram"),
        ("smc-modal-exact", "flash"),
        ("smc-modal-exact", "ram"),
    ],
    "docs/flash-a-drive.md": [("smc", "flash"), ("smc-modal", "flash"), ("smc-modal-exact", "flash")],
}


def size(elf):
    out = subprocess.run(["arm-none-eabi-size", elf], check=True, capture_output=True, text=True)
    text, data, bss = (int(v) for v in out.stdout.splitlines()[1].split()[:3])
    return {"flash": text + data, "ram": data + bss}


def quoted(n):
    return f"{n:,} B".replace(",", " ")


def main():
    if len(sys.argv) != 4:
        print(__doc__, file=sys.stderr)
        return 2
    boards = {"smc": size(sys.argv[1]), "smc-modal": size(sys.argv[2]), "smc-modal-exact": size(sys.argv[3])}
    stale = []
    for doc, figures in QUOTES.items():
        text = (ROOT / doc).read_text(encoding="utf-8")
        for board, figure in figures:
            want = quoted(boards[board][figure])
            if want not in text:
                stale.append(f"{doc} does not quote the {board} board's {figure}, {want} as measured")
    for board, figs in boards.items():
        print(f"{board} board: flash {quoted(figs['flash'])}, static RAM {quoted(figs['ram'])}")
    if stale:
        print("\n".join(stale), file=sys.stderr)
        print("the docs' figures are stale: update them to the measured ones", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
