#!/usr/bin/env bash
# Calibration on the drive's own log, closed back into the drive (docs/calibrate-your-rig.md):
# the emulated STM32F405 runs the paper's slew under PD 20/1 against the simulated beam and
# logs it (defmt telemetry); the model is identified from that log; gains are designed on the
# identified model into a new gain table (it names the found plant); the firmware is rebuilt
# with that table and run again in the emulator. Needs qemu-system-arm and the thumbv7em
# target. Run from the repository root; writes into ${1:-target/close-the-loop}. Only the
# firmware's crates are rebuilt for the new table (the host tools load it when they run);
# `cargo pil-fw` afterwards puts the emulated drive back on the shipped table.
set -euo pipefail
out=${1:-target/close-the-loop}
mkdir -p "$out"
out=$(cd "$out" && pwd)
# `cargo beam`, or the binary $BEAM names (CI gives it the one its tests built).
beam() { ${BEAM:-cargo -q beam} "$@"; }

echo "== 1. the drive's log: PD 20/1 on the emulated drive"
cargo -q pil-fw
beam pil --controller pd --telemetry "$out/drive.csv"

echo "== 2. calibrate on it (split; the density of aluminium known)"
beam calibrate "$out/drive.csv" --method split --known-density 2700 \
  --out "$out/found.toml" --plot "$out/calibration.png"

echo "== 3. the found model against the log"
beam replay "$out/drive.csv" --params "$out/found.toml"

echo "== 4. gains for the found model, into a new gain table for it"
rm -f "$out/gains.toml"
beam optimize --params "$out/found.toml" --controller pd-ff --shaper zvd --end-on-time \
  --load-hold 0.5 --torque-fraction 0.9 --max-err-deg 0.25 --samples 256 --starts 3 \
  --table "$out/gains.toml"

echo "== 5. the firmware built with that table, and the emulated drive run with it"
export BEAM_GAIN_TABLE="$out/gains.toml"
cargo -q fw
cargo -q pil-fw
beam pil --controller pd-ff
