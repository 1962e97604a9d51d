#!/usr/bin/env bash
# The drive built for a second plant: the steel strip of docs/other-rig.sh. Designs the SMC's
# payload-0 row for it into a new table, builds the firmware and the emulated drive with that
# table, and runs the paper's slew and a commanded 90 deg move on the emulated drive against
# the simulated steel beam; `beam pil` and `beam drive --pil` load the same table
# (`BEAM_GAIN_TABLE`) for the host's side of the comparison. Only the firmware's crates are
# rebuilt; `cargo fw && cargo pil-fw` afterwards put them back on the shipped table. Run from
# the repository root (needs QEMU and the thumbv7em target).
set -euo pipefail
# `cargo beam`, or the binary $BEAM names (CI gives it the one its tests built).
beam() { ${BEAM:-cargo -q beam} "$@"; }
table=${1:-target/steel-gains.toml}
rm -f "$table"
beam optimize --params docs/steel/steel-strip.toml --controller smc --table "$table"
export BEAM_GAIN_TABLE=$table
cargo -q fw
arm-none-eabi-size target/thumbv7em-none-eabihf/release/firmware
cargo -q pil-fw
beam pil --params docs/steel/steel-strip.toml --json
beam drive --pil --controller smc move 90 \; done \; status
