#!/usr/bin/env python3
"""The settle-time comparison of docs/results.md: every law with its shipped table rows,
moves of 15, 45, 90 and 180 deg at the planner's shortest time, over beams with EI, density,
Jm and friction within +-20 %, the damping ratio from 0.5 to 2 % (log-uniform), Coulomb
friction 0-0.05 N m and payload 0-50 g.

Runs `beam` (the host build: target/host/beam, made by `cargo build --profile host -p
beam-tools`) and prints a Markdown table. With --plot DIR it also writes the 180 deg
sweep's histograms (settle time and residual strain, against PD 20/1) for smc-modal, lqg
and pd-ff.
With --readme it prints the README's table instead: a row per law, a cell per move
(settle nominal / p50 / p95, s; peak torque and peak root strain over the sweep, N m and
microstrain), the observer laws again with the beam's true state fed to the law
(`--true-state`: what the observer costs), and smc-modal as a calibrated rig's drive
(`--exact --drive-knows-beam`: each beam known, its shortest moves planned exact).
Usage: docs/settle/compare.py [CASES] [--plot DIR] [--readme]
"""
import json
import os
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
# The host build, or the binary $BEAM names (CI gives it the one its tests built).
BEAM = os.environ.get("BEAM") or ROOT / "target" / "host" / "beam"
LAWS = ["pd-ff", "smc", "smc-i", "smc-strain", "lqg", "smc-modal"]
MOVES = [15, 45, 90, 180]
DURATION_S = 4.0
# The damping ratio's range: 0.5-2 %, log-uniform.
DAMPING = "0.005,0.02"
PLOTTED = ("smc-modal", "lqg", "pd-ff")
# The laws run again with the true state in place of their observer's estimate.
TRUE_STATE = ["lqg", "smc-modal"]
# The laws run again as a calibrated rig's drive would: each beam known, moves exact.
CALIBRATED = ["smc-modal"]


def beam(*args):
    out = subprocess.run([str(BEAM), *map(str, args)], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def nominal(law, deg, *extra):
    v = beam("simulate", "--controller", law, "--from", -deg / 2, "--move", deg / 2,
             "--time", "shortest", "--duration", DURATION_S, "--json", *extra)
    return v["settle_s"], v["move_end_s"], v["peak_torque_nm"]


def hold(law, *extra):
    # 0.5 N m at rest for 0.5 s, after the paper's slew has settled.
    v = beam("simulate", "--controller", law, "--duration", 3.5, "--load-nm", 0.5,
             "--load-at", 2.0, "--load-until", 2.5, "--json", *extra)
    return v.get("hold_max_dev_deg")


def spread(law, deg, cases, plot, *extra):
    args = ["sweep", "--controller", law, "--moves", deg, "--shortest", "--cases", cases,
            "--coulomb-max", 0.05, "--damping-ratio", DAMPING, "--no-peer",
            "--duration", DURATION_S, "--json", *extra]
    if plot:
        args += ["--plot", pathlib.Path(plot) / f"{law}-{deg}.png"]
    v = beam(*args)
    s = v["metrics"]["settle_s"] or {}
    m = v["metrics"]
    return (s.get("p50"), s.get("p95"), v["unsettled"], v["breakdowns"],
            m["peak_torque_nm"]["max"], m["peak_root_strain_ue"]["max"])


def fmt(x, unit=""):
    return "never" if x is None else f"{x:.2f}{unit}"


def readme(cases):
    print("| law | " + " | ".join(f"{d} deg" for d in MOVES)
          + f" | not settled of {cases * len(MOVES)} | hold 0.5 N m, deg |")
    print("|---|" + "---|" * len(MOVES) + "---|---|")
    # Each row: the law, its label, and the options of its nominal run, its sweep and its hold.
    rows = [(law, law, (), (), ()) for law in LAWS]
    rows += [(law, f"{law}, fed the true state", ("--true-state",), ("--true-state",),
              ("--true-state",)) for law in TRUE_STATE]
    # A calibrated drive: each beam known to its drive (its table made on it), its shortest
    # moves planned exact on the law's reference beam. The hold is the same law's.
    rows += [(law, f"{law}, each beam known, exact moves", ("--exact",),
              ("--exact", "--drive-knows-beam"), ()) for law in CALIBRATED]
    for law, label, at_nominal, over_spread, holding in rows:
        cells, unsettled = [], 0
        for deg in MOVES:
            s, _, _ = nominal(law, deg, *at_nominal)
            p50, p95, never, _, peak_max, strain_max = spread(law, deg, cases, None, *over_spread)
            unsettled += never
            cells.append(f"{fmt(s)} / {fmt(p50)} / {fmt(p95)}; {peak_max:.1f} N m, {strain_max:.0f} ue")
        print(f"| {label} | " + " | ".join(cells) + f" | {unsettled} | {fmt(hold(law, *holding))} |")
        sys.stdout.flush()


def main():
    cases = int(sys.argv[1]) if len(sys.argv) > 1 and sys.argv[1].isdigit() else 200
    if "--readme" in sys.argv:
        readme(cases)
        return
    plot = sys.argv[sys.argv.index("--plot") + 1] if "--plot" in sys.argv else None
    print(f"| law | move | settle nominal, s | p50 / p95 over {cases} beams, s | not settled / broke down | move end T, s | peak torque nominal / max, N m | hold 0.5 N m, deg |")
    print("|---|---|---|---|---|---|---|---|")
    for law in LAWS:
        held = hold(law)
        for deg in MOVES:
            s, t, peak = nominal(law, deg)
            figure = plot if deg == 180 and law in PLOTTED else None
            p50, p95, never, broke, peak_max, _ = spread(law, deg, cases, figure)
            print(f"| {law} | {deg} deg | {fmt(s)} | {fmt(p50)} / {fmt(p95)} | {never} / {broke} | {t:.3f} | {peak:.1f} / {peak_max:.1f} | {fmt(held)} |")
            sys.stdout.flush()


if __name__ == "__main__":
    main()
