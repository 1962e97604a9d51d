#!/usr/bin/env bash
# The raw logs of docs/calibrate-your-rig.md's walk-through ("Your own rig, from a raw CSV"):
# a teaching lab's rotary flexible link, made up here so that its truth is known. A spring
# steel blade (0.42 x 0.02 x 0.0009 m) on a geared hub, a 20 g mass at its tip, no strain
# gauge: a tip sensor reads the free end's deflection from the hub's line, in mm to
# 0.05 mm with noise, and lags the encoder by 15 ms (its filter); the torque is derived
# from the motor's current, in mN m, with 0.5 mN m of noise. Three PD moves, logged at
# 500 Hz, each from 0.5 s of rest: out (0 to +40 deg in 0.6 s) and back (+40 to 0 in
# 0.5 s) to calibrate on, and one held out (0 to -30 deg in 0.4 s).
#
# Writes docs/lab-link/{truth,guess}.toml and {out,back,held-out}.csv; run from the
# repository's root (the files it writes are committed: the walk-through reads them).
set -euo pipefail
dir=docs/lab-link
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# `cargo beam`, or the binary $BEAM names (CI gives it the one its tests built).
beam() { ${BEAM:-cargo -q beam} "$@"; }
python3 - "$dir" <<'PY'
import sys
out = sys.argv[1]
E, w, t, rho = 195e9, 0.02, 0.0009, 7900.0
truth = dict(length_m=0.42, width_m=w, thickness_m=t, hub_radius_m=0.02, density_kg_m3=rho,
             ei_nm2=E * w * t**3 / 12, jm_kgm2=0.0021, viscous_nms=0.004, coulomb_nm=0.01,
             tip_mass_kg=0.02, damping_ratio=0.012, root_gauge_m=0.0, mid_gauge_m=0.21,
             torque_limit_nm=2.0)
# What a user writes before calibrating: the blade measured with a ruler and calipers, the
# handbook's steel (200 GPa, 7850 kg/m^3), the weighed tip mass, the hub's inertia from the
# motor's and gearhead's data sheets (25 % high: the gear's share is a guess), no friction.
guess = dict(truth, ei_nm2=200e9 * w * t**3 / 12, density_kg_m3=7850.0, jm_kgm2=0.0021 * 1.25,
             viscous_nms=0.0, coulomb_nm=0.0, damping_ratio=0.01)
notes = {'truth': 'the made-up truth the logs were simulated on (a user never has this file)',
         'guess': "a user's starting parameters: ruler, handbook steel, data-sheet hub inertia"}
for name, d in (('truth', truth), ('guess', guess)):
    with open(f'{out}/{name}.toml', 'w') as f:
        f.write(f'# The lab link of docs/calibrate-your-rig.md: {notes[name]}.\n')
        f.writelines(f'{k} = {float(v)!r}\n' for k, v in d.items())
PY
beam simulate --params "$dir/truth.toml" --controller pd --from 0 --move 40 --time 0.6 --duration 2.5 --csv "$tmp/out.csv" > /dev/null
beam simulate --params "$dir/truth.toml" --controller pd --from 40 --move 0 --time 0.5 --duration 2.5 --csv "$tmp/back.csv" > /dev/null
beam simulate --params "$dir/truth.toml" --controller pd --from 0 --move -30 --time 0.4 --duration 2.5 --csv "$tmp/held-out.csv" > /dev/null
python3 - "$tmp" "$dir" <<'PY'
import csv, math, random, sys
tmp, out = sys.argv[1:]
random.seed(21)
REST, LAG, STEP = 0.5, 0.015, 2   # s of rest before, the tip sensor's lag, 1 kHz to 500 Hz
for name in ('out', 'back', 'held-out'):
    rows = list(csv.DictReader(open(f'{tmp}/{name}.csv')))
    dt = float(rows[1]['t_s']) - float(rows[0]['t_s'])
    lag = round(LAG / dt)
    rest = round(REST / dt)
    # The beam at rest before the command: the hub where it starts, no torque, no deflection.
    first = rows[0]
    hub = [float(first['theta_rad'])] * rest + [float(r['theta_rad']) for r in rows]
    tau = [0.0] * rest + [float(r['torque_nm']) for r in rows]
    tip = [0.0] * (rest + lag) + [float(r['w_tip_m']) for r in rows][:len(rows) - lag]
    with open(f'{out}/{name}.csv', 'w') as f:
        f.write('time_ms,hub_deg,tip_mm,torque_mNm,motor_V\n')
        for k in range(0, len(hub), STEP):
            tip_mm = round((tip[k] * 1e3 + random.gauss(0, 0.03)) / 0.05) * 0.05
            tau_mnm = tau[k] * 1e3 + random.gauss(0, 0.5)
            volts = tau[k] / 0.05 * 2.1   # a column the calibration does not read
            f.write(f'{1000.0 * k * dt:.0f},{math.degrees(hub[k]):.4f},{tip_mm:.2f},'
                    f'{tau_mnm:.1f},{volts:.3f}\n')
PY
echo "wrote $dir/truth.toml, guess.toml, out.csv, back.csv, held-out.csv"
