#!/usr/bin/env python3
"""The shortest rest-to-rest move any torque could make within the drive's limits, on the
beam's linear model: a lower bound on the move's end (and so on its settle time) that holds
for every reference, shaper and law, against which docs/design.md (section 3, "How far the
move is from the shortest any torque could make") compares the planner's moves.

The beam is `beam model --json` (the assumed-modes model the drive is designed on, all its
modes, undamped): `[Mtt h'; h Mqq] [theta''; q''] + [0; Kqq q] = [tau; 0]`, the torque held
over each 1 ms tick, as the drive holds it (sampled exactly). A move of D from rest to rest
in n ticks is a linear program in the n torques: every tick within +-TORQUE, the hub's rate
within +-SPEED and the root strain within +-STRAIN at every tick, and at the end the hub on
the target and every mode and rate at zero. The shortest n is found by bisection on the
program's feasibility (HiGHS, through SciPy's linprog). Friction, damping and the
centrifugal stiffening are left out, so it is a bound on this model: on the beam each moves
it a little, either way (the friction is under 1 % of the torque, the damping 0.5-2 %, and
the stiffening shortens the first mode's period at speed by up to a tenth).

Also printed: the rigid body's shortest move (bang-coast-bang at the torque and speed
limits), which no flexible beam can beat.

Needs NumPy and SciPy (`pip install numpy scipy`; nothing else in the project does). Runs
`beam` (target/host/beam, or the binary $BEAM names).
Usage: docs/settle/bound.py [--deg D,...] [--strain-ue S] [--torque-nm T] [--speed R]
                            [--modes N] [--tip-mass KG]
"""
import argparse
import json
import math
import os
import pathlib
import subprocess

try:
    import numpy as np
    from scipy.linalg import expm
    from scipy.optimize import linprog
except ImportError as e:
    raise SystemExit(f"bound.py needs NumPy and SciPy (pip install numpy scipy): {e}")

ROOT = pathlib.Path(__file__).resolve().parents[2]
BEAM = os.environ.get("BEAM") or ROOT / "target" / "host" / "beam"
TS_S = 1e-3


def model(modes, tip_mass):
    args = [str(BEAM), "model", "--json", "--modes", str(modes)]
    if tip_mass:
        args += ["--tip-mass", str(tip_mass)]
    try:
        run = subprocess.run(args, capture_output=True, text=True)
    except OSError as e:
        raise SystemExit(f"cannot run {BEAM} ({e}): cargo build --profile host -p beam-tools")
    if run.returncode != 0:
        raise SystemExit(f"{' '.join(args)} failed: {run.stderr.strip()}")
    return json.loads(run.stdout)


def sampled(m):
    """The beam's state `[theta, q, theta', q']` sampled at the tick, torque held: (Ad, Bd),
    the root strain's row and the hub rate's row."""
    n = m["modes"]
    mass = np.zeros((n + 1, n + 1))
    mass[0, 0] = m["mtt"]
    mass[0, 1:] = m["h"]
    mass[1:, 0] = m["h"]
    mass[1:, 1:] = np.array(m["mqq"])
    stiff = np.zeros((n + 1, n + 1))
    stiff[1:, 1:] = np.array(m["kqq"])
    minv = np.linalg.inv(mass)
    s = 2 * (n + 1)
    cont = np.zeros((s + 1, s + 1))
    cont[: n + 1, n + 1 : s] = np.eye(n + 1)
    cont[n + 1 : s, : n + 1] = -minv @ stiff
    cont[n + 1 : s, s] = minv[:, 0]
    d = expm(cont * TS_S)
    strain = np.zeros(s)
    strain[1 : n + 1] = m["root_strain_coef"]
    rate = np.zeros(s)
    rate[n + 1] = 1.0
    return d[:s, :s], d[:s, s], strain, rate


def feasible(ticks, dist, beam, strain_max, torque_max, speed_max):
    ad, bd, strain, rate = beam
    s = len(bd)
    # resp[k] maps the torques to the state after tick k.
    resp = np.zeros((ticks + 1, s, ticks))
    for k in range(ticks):
        resp[k + 1] = ad @ resp[k]
        resp[k + 1][:, k] += bd
    e = np.einsum("i,kij->kj", strain, resp[1:])
    w = np.einsum("i,kij->kj", rate, resp[1:])
    a_ub = np.vstack([e, -e, w, -w])
    b_ub = np.concatenate([np.full(ticks, strain_max)] * 2 + [np.full(ticks, speed_max)] * 2)
    end = np.zeros(s)
    end[0] = dist
    r = linprog(
        np.zeros(ticks),
        A_ub=a_ub,
        b_ub=b_ub,
        A_eq=resp[ticks],
        b_eq=end,
        bounds=[(-torque_max, torque_max)] * ticks,
        method="highs",
    )
    return r.status == 0


def shortest(dist, beam, strain_max, torque_max, speed_max, t_rigid):
    """The fewest ticks, s; None if no move within a second does it. From the rigid
    body's time, which bounds it below, doubling until one is feasible."""
    lo = max(1, int(t_rigid / TS_S) - 1)
    hi = 2 * lo
    while not feasible(hi, dist, beam, strain_max, torque_max, speed_max):
        lo, hi = hi, 2 * hi
        if hi * TS_S > 1.0:
            return None
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if feasible(mid, dist, beam, strain_max, torque_max, speed_max):
            hi = mid
        else:
            lo = mid
    return hi * TS_S


def rigid(dist, inertia, torque_max, speed_max):
    acc = torque_max / inertia
    if dist * acc <= speed_max**2:
        return 2 * math.sqrt(dist / acc)
    return dist / speed_max + speed_max / acc


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--deg", default="15,45,90,180", help="move lengths, deg")
    p.add_argument("--strain-ue", type=float, default=2000.0, help="root strain bound, ue")
    p.add_argument("--torque-nm", type=float, default=10.0, help="torque bound, N m")
    p.add_argument("--speed", type=float, default=20.0, help="hub rate bound, rad/s")
    p.add_argument("--modes", type=int, default=3)
    p.add_argument("--tip-mass", type=float, default=0.0, help="payload, kg")
    a = p.parse_args()
    if not all(x > 0 for x in (a.strain_ue, a.torque_nm, a.speed)):
        p.error("the strain, torque and speed bounds must be positive")
    degs = [float(x) for x in a.deg.split(",")]
    if not all(0 < d <= 360 for d in degs):
        p.error("each move must be over 0 and at most 360 deg (the program grows with its square)")
    m = model(a.modes, a.tip_mass)
    beam = sampled(m)
    print(
        f"{a.modes} modes, {a.tip_mass:g} kg; torque {a.torque_nm:g} N m, "
        f"hub rate {a.speed:g} rad/s, root strain {a.strain_ue:g} ue"
    )
    print("| move, deg | rigid body, s | the beam at rest at the end, s |")
    print("| --- | --- | --- |")
    for deg in degs:
        dist = math.radians(deg)
        t_rigid = rigid(dist, m["mtt"], a.torque_nm, a.speed)
        t = shortest(dist, beam, a.strain_ue * 1e-6, a.torque_nm, a.speed, t_rigid)
        print(f"| {deg:g} | {t_rigid:.3f} | {'none' if t is None else f'{t:.3f}'} |")


if __name__ == "__main__":
    main()
