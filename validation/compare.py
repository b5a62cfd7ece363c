#!/usr/bin/env python3
"""Compare a run's profiles.csv with a measured profile (validation/*/*.csv).

Usage: validation/compare.py MEASURED.csv RUN_DIR [--slope RAD] [--s S] [--d M]
(a missing or unreadable file, or a column it lacks, is an error naming it:
exit 2).

Prints, for the run's (first) tau*:
- the bed surface of each profile: the highest height where phi, smoothed
  over 1 d, is at least half its bed value (the mean of the smoothed phi over
  the 3 d above the lowest height of the measured data, or above y = 1 d for
  the run);
- the rms differences of phi and u_p (and u_f when measured) over the
  transport layer (measured heights where phi u_p >= 1 % of its largest value),
  with no shift and with the shift that aligns the two bed surfaces;
- q* of the measured profile (integral of phi u_p dz over
  sqrt((s - 1) g cos(theta) d^3)), of the run's profile, and transport.csv's;
- where the reference has them (r2d6s2), the rms differences of the shear
  stresses: the grains' (contacts and fluctuations), the fluid's viscous and
  Reynolds stresses, and their total against the weight of what lies above,
  over the heights above the fixed layer (z >= 1 d).
Standard library only.
"""
import argparse
import csv
import math
import os
import sys

# The largest file read: 16 MiB (a profile of some 300 000 heights).
BOUND = 16 << 20


class Refused(Exception):
    """Bad input: the message names the file and what is wrong."""


def read(path, columns, least=2):
    try:
        with open(path, newline="") as f:
            text = f.read(BOUND + 1)
            if len(text) > BOUND:
                raise Refused(f"{path}: longer than {BOUND >> 20} MiB, the largest profile: refused")
            rows = list(csv.DictReader(text.splitlines()))
    except OSError as e:
        raise Refused(f"{path}: {e.strerror}")
    except (csv.Error, UnicodeDecodeError) as e:
        raise Refused(f"{path}: not a CSV file ({e})")
    if len(rows) < least:
        raise Refused(f"{path}: {len(rows)} rows; at least {least} needed")
    missing = [c for c in columns if c not in rows[0]]
    if missing:
        raise Refused(f"{path}: no column {', '.join(missing)}")
    return rows


def number(path, row, column):
    try:
        x = float(row[column] or 0.0)
    except ValueError:
        raise Refused(f"{path}: {column} = {row[column]!r} is not a number")
    if not math.isfinite(x):
        raise Refused(f"{path}: {column} = {row[column]!r} is not finite")
    return x


def heights(path, zs):
    """zs, if strictly increasing (interpolation needs it); else refused."""
    for a, b in zip(zs, zs[1:]):
        if not b > a:
            raise Refused(f"{path}: heights must increase from row to row ({a} then {b})")
    return zs


def within(path, column, vs, lo, hi):
    """vs, if every value lies in [lo, hi]; else refused naming the first."""
    for v in vs:
        if not lo <= v <= hi:
            raise Refused(f"{path}: {column} = {v} must be in [{lo}, {hi}]")
    return vs


def interp(xs, ys, x):
    if x <= xs[0]:
        return ys[0]
    if x >= xs[-1]:
        return ys[-1]
    lo, hi = 0, len(xs) - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if xs[mid] <= x:
            lo = mid
        else:
            hi = mid
    t = (x - xs[lo]) / (xs[hi] - xs[lo])
    return ys[lo] + t * (ys[hi] - ys[lo])


def smooth(zs, vs, width=1.0):
    out = []
    for z in zs:
        w = [v for zz, v in zip(zs, vs) if abs(zz - z) <= width / 2]
        out.append(sum(w) / len(w))
    return out


def surface(zs, phi, z0):
    sm = smooth(zs, phi)
    bed = [p for z, p in zip(zs, sm) if z0 <= z <= z0 + 3.0]
    if not bed or sum(bed) <= 0:
        return 0.0, None
    phi_b = sum(bed) / len(bed)
    half = phi_b / 2
    top = None
    for i in range(len(zs) - 1):
        if sm[i] >= half > sm[i + 1]:
            top = zs[i] + (sm[i] - half) / (sm[i] - sm[i + 1]) * (zs[i + 1] - zs[i])
    return phi_b, top


def trapz(zs, vs):
    return sum(0.5 * (vs[i] + vs[i + 1]) * (zs[i + 1] - zs[i]) for i in range(len(zs) - 1))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("measured", help="a measured profile: z_over_d, solid_fraction, particle_velocity_m_s[, fluid_velocity_m_s]")
    ap.add_argument("run", help="an mbs output directory (profiles.csv, transport.csv)")
    ap.add_argument("--slope", type=float, default=0.1, help="bed slope (rad), for q*'s g cos(theta)")
    ap.add_argument("--s", type=float, default=2.5, help="specific gravity")
    ap.add_argument("--d", type=float, default=0.006, help="grain diameter (m)")
    a = ap.parse_args()
    if not (0 <= a.slope < 0.5 and a.s > 1 and a.d > 0):
        raise Refused(f"--slope {a.slope} (in [0, 0.5)), --s {a.s} (> 1), --d {a.d} (> 0)")
    theta, s, d, measured, run = a.slope, a.s, a.d, a.measured, a.run
    scale = math.sqrt((s - 1) * 9.81 * math.cos(theta) * d**3)

    mcols = ["z_over_d", "solid_fraction", "particle_velocity_m_s"]
    m = read(measured, mcols)
    mz, mphi, mup = ([number(measured, r, c) for r in m] for c in mcols)
    heights(measured, mz)
    within(measured, "solid_fraction", mphi, 0.0, 1.0)
    within(measured, "particle_velocity_m_s", mup, -100.0, 100.0)
    has_uf = "fluid_velocity_m_s" in m[0]
    muf = [number(measured, r, "fluid_velocity_m_s") for r in m] if has_uf else None

    prof = run + "/profiles.csv"
    pcols = ["tau_star", "y_over_d", "solid_fraction", "grain_velocity_m_s", "fluid_velocity_m_s"]
    p = read(prof, pcols)
    tau = p[0]["tau_star"]
    p = [r for r in p if r["tau_star"] == tau]
    if len(p) < 2:
        raise Refused(f"{prof}: {len(p)} rows at tau* {tau}; a profile needs at least 2")
    pz, pphi, pup, puf = ([number(prof, r, c) for r in p] for c in pcols[1:])
    heights(prof, pz)
    within(prof, "solid_fraction", pphi, 0.0, 1.0)
    report(measured, run, tau, d, scale, mz, mphi, mup, muf, pz, pphi, pup, puf)
    stresses(measured, m, mz, prof, p, pz)


STRESSES = ["contact_stress_pa", "kinetic_stress_pa", "viscous_stress_pa", "reynolds_stress_pa"]


def stresses(measured, m, mz, prof, p, pz):
    """The shear stresses against the reference's (r2d6s2: tau_xz the
    grains', S_xz the fluid's viscous, R_xz its Reynolds stress, and their
    sum's budget, gravity_term), rms over its heights, when both have them."""
    ref_cols = ["tau_xz", "S_xz", "R_xz", "gravity_term"]
    if not all(c in m[0] for c in ref_cols) or not all(c in p[0] for c in STRESSES):
        return
    contact, kinetic, viscous, reynolds = ([number(prof, r, c) for r in p] for c in STRESSES)
    grains = [a + b for a, b in zip(contact, kinetic)]
    total = [a + b + c for a, b, c in zip(grains, viscous, reynolds)]
    # Above the fixed layer (z >= 1 d), where both beds are mobile grains.
    above = [i for i, z in enumerate(mz) if z >= 1.0]
    ref = {c: [number(measured, r, c) for r in m] for c in ref_cols}
    for name, model, key in (("grains", grains, "tau_xz"), ("viscous", viscous, "S_xz"),
                             ("Reynolds", reynolds, "R_xz"), ("total", total, "gravity_term")):
        e = [interp(pz, model, mz[i]) - ref[key][i] for i in above]
        print(f"shear stress over z >= 1 d, {name}: rms {math.sqrt(sum(x * x for x in e) / len(e)):.2f} Pa "
              f"against {key} (largest {max(abs(ref[key][i]) for i in above):.2f} Pa)")


def report(measured, run, tau, d, scale, mz, mphi, mup, muf, pz, pphi, pup, puf):
    mb, ms = surface(mz, mphi, mz[0] if mz[0] > 1.0 else 1.0)
    pb, ps = surface(pz, pphi, 1.0)
    if ms is None or ps is None:
        raise Refused(f"no bed surface (half phi) in {measured if ms is None else run + '/profiles.csv'}")
    print(f"tau* {float(tau):.4f}")
    print(f"bed phi: measured {mb:.3f}, run {pb:.3f}; surface (half phi): measured {ms:.2f} d, run {ps:.2f} d")

    flux = [a * b for a, b in zip(mphi, mup)]
    fmax = max(flux)
    if fmax <= 0:
        raise Refused(f"{measured}: no transport (phi u_p is nowhere positive)")
    layer = [i for i, f in enumerate(flux) if f >= 0.01 * fmax]
    print(f"transport layer: measured z in [{mz[layer[0]]:.2f}, {mz[layer[-1]]:.2f}] d, {len(layer)} points")
    for name, shift in (("no shift", 0.0), ("surfaces aligned", ms - ps)):
        def rms(model, meas):
            e = [interp(pz, model, mz[i] - shift) - meas[i] for i in layer]
            return math.sqrt(sum(x * x for x in e) / len(e))
        line = (f"{name} (run y = z - {shift:.2f} d): rms phi {rms(pphi, mphi):.3f}, "
                f"rms u_p {rms(pup, mup):.3f} m/s (max measured {max(mup):.3f})")
        if muf:
            line += f", rms u_f {rms(puf, muf):.3f} m/s (max measured {max(muf):.3f})"
        print(line)
    q_meas = trapz([z * d for z in mz], flux) / scale
    q_prof = trapz([z * d for z in pz], [a * b for a, b in zip(pphi, pup)]) / scale
    tpath = run + "/transport.csv"
    t = read(tpath, ["q_star", "q_star_stderr"], least=1)[0]
    q, q_err = number(tpath, t, "q_star"), number(tpath, t, "q_star_stderr")
    ratio = f"{q / q_meas:.2f}" if q_meas > 0 else "undefined (no measured transport)"
    print(f"q*: measured {q_meas:.3f}, run profile {q_prof:.3f}, run transport.csv {q:.3f}"
          f" +- {q_err:.3f}; ratio {ratio}")
    grains = [i for i, f in enumerate(pphi) if f > 1e-3]
    if not grains:
        raise Refused(f"{run}/profiles.csv: no grains (phi > 1e-3 nowhere)")
    top = max(grains)
    print(f"max u_p (phi > 1e-3): run {pup[top]:.3f} m/s at {pz[top]:.2f} d; measured {max(mup):.3f}")
    if muf:
        above = [i for i, z in enumerate(mz) if z >= ms]
        e = [interp(pz, puf, mz[i]) - muf[i] for i in above] or [0.0]
        print(f"u_f over the water above the measured surface (no shift): rms {math.sqrt(sum(x * x for x in e) / len(e)):.3f} m/s")
        print(f"u_f at the surface: run {puf[-1]:.3f}, measured {muf[-1]:.3f} m/s")


if __name__ == "__main__":
    try:
        main()
    except Refused as e:
        print(f"error: {e}", file=sys.stderr)
        sys.exit(2)
    except (ArithmeticError, ValueError, IndexError, KeyError) as e:
        # A safety net: input that passed the checks above and still cannot
        # be compared is named, never a traceback.
        print(f"error: {sys.argv[1:3]} cannot be compared: {type(e).__name__}: {e}", file=sys.stderr)
        sys.exit(2)
