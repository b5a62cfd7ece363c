#!/usr/bin/env python3
"""Compare a run's profiles.csv with a measured profile (validation/*/*.csv).

Usage: validation/compare.py MEASURED.csv RUN_DIR [--slope RAD] [--s S] [--d M]

Prints, for the run's (first) tau*:
- the bed surface of each profile: the highest height where phi, smoothed
  over 1 d, is at least half its bed value (the mean of the smoothed phi over
  the 3 d above the lowest height of the measured data, or above y = 1 d for
  the run);
- the rms differences of phi and u_p (and u_f when measured) over the
  transport layer (measured heights where phi u_p >= 1 % of its largest value),
  with no shift and with the shift that aligns the two bed surfaces;
- q* of the measured profile (integral of phi u_p dz over
  sqrt((s - 1) g cos(theta) d^3)), of the run's profile, and transport.csv's.
Standard library only.
"""
import csv
import math
import sys


def read(path):
    with open(path) as f:
        return list(csv.DictReader(f))


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
    args = sys.argv[1:]
    opts = {"--slope": 0.1, "--s": 2.5, "--d": 0.006}
    pos = []
    while args:
        a = args.pop(0)
        if a in opts:
            opts[a] = float(args.pop(0))
        else:
            pos.append(a)
    measured, run = pos
    theta, s, d = opts["--slope"], opts["--s"], opts["--d"]
    scale = math.sqrt((s - 1) * 9.81 * math.cos(theta) * d**3)

    m = read(measured)
    mz = [float(r["z_over_d"]) for r in m]
    mphi = [float(r["solid_fraction"]) for r in m]
    mup = [float(r["particle_velocity_m_s"]) for r in m]
    muf = [float(r["fluid_velocity_m_s"]) for r in m] if "fluid_velocity_m_s" in m[0] else None

    p = read(run + "/profiles.csv")
    tau = p[0]["tau_star"]
    p = [r for r in p if r["tau_star"] == tau]
    pz = [float(r["y_over_d"]) for r in p]
    pphi = [float(r["solid_fraction"]) for r in p]
    pup = [float(r["grain_velocity_m_s"] or 0.0) for r in p]
    puf = [float(r["fluid_velocity_m_s"]) for r in p]

    mb, ms = surface(mz, mphi, mz[0] if mz[0] > 1.0 else 1.0)
    pb, ps = surface(pz, pphi, 1.0)
    print(f"tau* {float(tau):.4f}")
    print(f"bed phi: measured {mb:.3f}, run {pb:.3f}; surface (half phi): measured {ms:.2f} d, run {ps:.2f} d")

    flux = [a * b for a, b in zip(mphi, mup)]
    fmax = max(flux)
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
    t = read(run + "/transport.csv")[0]
    print(f"q*: measured {q_meas:.3f}, run profile {q_prof:.3f}, run transport.csv {float(t['q_star']):.3f}"
          f" +- {float(t['q_star_stderr']):.3f}; ratio {float(t['q_star']) / q_meas:.2f}")
    top = max(i for i, f in enumerate(pphi) if f > 1e-3)
    print(f"max u_p (phi > 1e-3): run {pup[top]:.3f} m/s at {pz[top]:.2f} d; measured {max(mup):.3f}")
    if muf:
        above = [i for i, z in enumerate(mz) if z >= ms]
        e = [interp(pz, puf, mz[i]) - muf[i] for i in above]
        print(f"u_f over the water above the measured surface (no shift): rms {math.sqrt(sum(x * x for x in e) / len(e)):.3f} m/s")
        print(f"u_f at the surface: run {puf[-1]:.3f}, measured {muf[-1]:.3f} m/s")


main()
