#!/usr/bin/env bash
# The drive built for a second plant: the steel strip of docs/other-rig.sh. Designs the SMC's
# payload-0 row for it into a new table, builds the firmware, the PIL drive and the host
# tools with that table (in their own target directory, so the aluminium build stays), and
# runs the paper's slew and a commanded 90 deg move on the emulated drive against the
# simulated steel beam. Run from the repository root; about 5 minutes cold (needs QEMU).
set -euo pipefail
table=${1:-target/steel-gains.toml}
rm -f "$table"
cargo -q beam optimize --params docs/steel/steel-strip.toml --controller smc --table "$table"
export BEAM_GAIN_TABLE=$table CARGO_TARGET_DIR=target/steel
cargo fw
arm-none-eabi-size "$CARGO_TARGET_DIR/thumbv7em-none-eabihf/release/firmware"
elf=$CARGO_TARGET_DIR/thumbv7em-none-eabihf/release/pil
cargo -q beam pil --params docs/steel/steel-strip.toml --elf "$elf" --json
cargo -q beam drive --pil --controller smc --elf "$elf" move 90 \; done \; status
