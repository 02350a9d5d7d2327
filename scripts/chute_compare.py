#!/usr/bin/env python3
"""sweep against LAMMPS on the same sphere chute (scripts/compare-lammps-chute.sh runs both).

Both codes are measured the same way: snapshots every `interval` (sweep's particle frames,
LAMMPS's `fix ave/chunk` with one sample per output), binned in dz from the base spheres'
centres (z = 0) by particle centre; V_x(z) = sum(v_x) / count per bin, phi(z) = count V_p /
(Lx Ly dz). Over the window [t0, t1] the samples are cut into blocks of `block` s; each value is
the mean of its block means, its error the standard error of those (blocks longer than the
flow's correlation time are independent). The kinetic energy (translational + rotational, the
flowing spheres) is compared the same way. sweep's own chute observer (coarse-grained V_x(z),
phi(z) of its measurement window, `chute_fields`) is printed beside them as a cross-check.

usage: chute_compare.py SWEEP_DB SWEEP_FRAMES_DIR LAMMPS_DIR --t0 T0 --t1 T1 [--block B]
prints the history, the profiles and the verdict as markdown; exit 0 when it passes, 1 if not.
"""
import argparse
import glob
import math
import os
import re
import sqlite3
import struct
import sys


def read_frame(path):
    """(job time, [(z, vx) of each flowing particle]) from a sweep frame (observe/snapshots)."""
    b = open(path, "rb").read()
    assert b[:8] == b"SWEEPSN\0", path
    o = 8
    _version, hl = struct.unpack_from("<II", b, o)
    o += 8 + hl
    _chunk, _step, _sim_t, job_t, n, flags = struct.unpack_from("<QQddQI", b, o)
    o += 8 + 8 + 8 + 8 + 8 + 4
    o += 4 * n  # ids
    pos = struct.unpack_from(f"<{3 * n}d", b, o)
    o += 24 * n
    vel = struct.unpack_from(f"<{3 * n}d", b, o)
    o += 24 * n
    if flags & 1:
        o += 24 * n
    o += 8 * n  # radii
    fixed = b[o:o + n]
    return job_t, [(pos[3 * i + 2], vel[3 * i]) for i in range(n) if fixed[i] == 0]


def bin_sample(particles, dz, nbins):
    count, sx = [0] * nbins, [0.0] * nbins
    for z, vx in particles:
        k = int(math.floor(z / dz))
        if 0 <= k < nbins:
            count[k] += 1
            sx[k] += vx
    return count, sx


def sweep_samples(frames_dir, dz, nbins):
    out = []
    for f in sorted(glob.glob(os.path.join(frames_dir, "frame-*.snap"))):
        t, parts = read_frame(f)
        out.append((t,) + bin_sample(parts, dz, nbins))
    return out


def lammps_samples(path, dt, dz, nbins):
    """(t, count, sum vx) per `fix ave/chunk` output (bins from z = 0 are chunks with
    coordinate > 0)."""
    out, cur = [], None
    for line in open(path):
        if line.startswith("#"):
            continue
        w = line.split()
        if len(w) == 3:
            cur = (int(w[0]) * dt, [0] * nbins, [0.0] * nbins)
            out.append(cur)
            continue
        z, n, vx = float(w[1]), float(w[2]), float(w[3])
        k = int(math.floor(z / dz))
        if 0 <= k < nbins:
            cur[1][k] += int(round(n))
            cur[2][k] += n * vx
    return out


def blocks(samples, t0, t1, block):
    """Samples of [t0, t1] grouped into consecutive blocks of `block` s."""
    out = {}
    for s in samples:
        if t0 - 1e-9 <= s[0] <= t1 + 1e-9:
            out.setdefault(min(int((s[0] - t0) / block), int((t1 - t0) / block) - 1), []).append(s)
    return [out[k] for k in sorted(out)]


def mean_err(values):
    n = len(values)
    m = sum(values) / n
    if n < 2:
        return m, float("nan")
    var = sum((v - m) ** 2 for v in values) / (n - 1)
    return m, math.sqrt(var / n)


def profiles(bl, nbins, dz, area, vp):
    """Per bin: (phi mean, err), (V_x mean, err) over the blocks (None where a block is empty)."""
    phi, vx = [], []
    for k in range(nbins):
        ph, v = [], []
        for b in bl:
            c = sum(s[1][k] for s in b)
            ph.append(c / len(b) * vp / (area * dz))
            if c > 0:
                v.append(sum(s[2][k] for s in b) / c)
        phi.append(mean_err(ph))
        vx.append(mean_err(v) if len(v) == len(bl) else None)
    return phi, vx


def energy_sweep(db):
    c = sqlite3.connect(db)
    return c.execute("SELECT t_s, kinetic_energy_j FROM chute_series ORDER BY t_s").fetchall()


def observer_profile(db):
    """sweep's own chute observer over its measurement window (coarse-grained, `chute_fields`):
    [(z, density, V_x)], a cross-check of the frame binning."""
    c = sqlite3.connect(db)
    return c.execute(
        "SELECT z_m, density_kg_per_m3, velocity_x_m_per_s FROM chute_fields ORDER BY z_m"
    ).fetchall()


def interpolate(rows, z, col):
    for a, b in zip(rows, rows[1:]):
        if a[0] <= z <= b[0]:
            w = (z - a[0]) / (b[0] - a[0]) if b[0] > a[0] else 0.0
            return a[col] + w * (b[col] - a[col])
    return float("nan")


def energy_lammps(path, dt):
    out = []
    for line in open(path):
        if line.startswith("#"):
            continue
        step, ket, ker, _vcm = line.split()
        out.append((int(step) * dt, float(ket) + float(ker)))
    return out


def block_mean(series, t0, t1, block):
    nb = int((t1 - t0) / block)
    means = []
    for k in range(nb):
        v = [e for t, e in series if t0 + k * block - 1e-9 <= t < t0 + (k + 1) * block - 1e-9]
        if v:
            means.append(sum(v) / len(v))
    return mean_err(means)


def trend(series, t0, t1, block):
    """Least-squares slope of the block means against time, times the window, relative to the
    mean, with its standard error (block means taken as independent)."""
    nb = int((t1 - t0) / block)
    pts = []
    for k in range(nb):
        v = [e for t, e in series if t0 + k * block - 1e-9 <= t < t0 + (k + 1) * block - 1e-9]
        if v:
            pts.append((t0 + (k + 0.5) * block, sum(v) / len(v)))
    n = len(pts)
    if n < 3:
        return None
    tm = sum(t for t, _ in pts) / n
    em = sum(e for _, e in pts) / n
    stt = sum((t - tm) ** 2 for t, _ in pts)
    slope = sum((t - tm) * (e - em) for t, e in pts) / stt
    res = sum((e - em - slope * (t - tm)) ** 2 for t, e in pts) / max(n - 2, 1)
    err = math.sqrt(res / stt)
    w = t1 - t0
    if em == 0:
        return None
    return slope * w / em, err * w / em


def at(series, t):
    return min(series, key=lambda s: abs(s[0] - t))[1]


def surface(phi, dz):
    """Bed height h: where phi first falls below half its bulk value (bins 4 d .. 10 d)."""
    bulk = [p[0] for k, p in enumerate(phi) if 4 <= (k + 0.5) * dz <= 10]
    half = 0.5 * sum(bulk) / len(bulk)
    for k in range(len(phi) - 1, 0, -1):
        if phi[k][0] >= half:
            # Linear interpolation between bin k (above half) and k + 1 (below).
            nxt = phi[k + 1][0] if k + 1 < len(phi) else 0.0
            return (k + 0.5) * dz + dz * (phi[k][0] - half) / max(phi[k][0] - nxt, 1e-12)
    return 0.0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("db")
    ap.add_argument("frames")
    ap.add_argument("lammps")
    ap.add_argument("--t0", type=float, required=True)
    ap.add_argument("--t1", type=float, required=True)
    ap.add_argument("--block", type=float, default=5.0)
    ap.add_argument("--dz", type=float, default=1.0)
    ap.add_argument("--tol-v", type=float, default=0.05)
    ap.add_argument("--tol-phi", type=float, default=0.02)
    a = ap.parse_args()
    text = open(os.path.join(a.lammps, "in.chute")).read()
    dt = float(re.search(r"^timestep (\S+)", text, re.M).group(1))
    data = open(os.path.join(a.lammps, "data.chute")).read()
    lx = float(re.search(r"^0e0 (\S+) xlo xhi", data, re.M).group(1))
    ly = float(re.search(r"^0e0 (\S+) ylo yhi", data, re.M).group(1))
    d = float(next(l.split()[2] for l in data.split("Atoms # sphere")[1].splitlines()
                   if l.strip() and l.split()[1] == "1"))
    vp = math.pi / 6 * d ** 3
    nbins = 60
    sw = sweep_samples(a.frames, a.dz, nbins)
    lm = lammps_samples(os.path.join(a.lammps, "profile.txt"), dt, a.dz, nbins)
    es, el = energy_sweep(a.db), energy_lammps(os.path.join(a.lammps, "ke.txt"), dt)
    print(f"## Kinetic energy history (flowing spheres, translational + rotational)\n")
    print("| t | sweep | LAMMPS |\n|---:|---:|---:|")
    t_end = min(es[-1][0], el[-1][0])
    t = 0.0
    while t <= t_end + 1e-9:
        print(f"| {t:.0f} | {at(es, t):.0f} | {at(el, t):.0f} |")
        t += 10.0 if t_end > 40 else 5.0
    ke_s, ke_l = block_mean(es, a.t0, a.t1, a.block), block_mean(el, a.t0, a.t1, a.block)
    # Each code's trend over the window: the first and last thirds' block means.
    bs, bl_ = blocks(sw, a.t0, a.t1, a.block), blocks(lm, a.t0, a.t1, a.block)
    # Each code must have measured the window: two blocks at least, for a mean and its error.
    short = [f"{who} has {len(b)} block(s) of {a.block} in [{a.t0}, {a.t1}] (its record ends at "
             f"t = {series[-1][0]:.1f})" for who, b, series in (("sweep", bs, es), ("LAMMPS", bl_, el))
             if len(b) < 2]
    if short:
        print("\nNOT COMPARABLE: " + "; ".join(short) + ". Run both codes through the window.")
        return 3
    area = lx * ly
    ps, vs = profiles(bs, nbins, a.dz, area, vp)
    pl, vl = profiles(bl_, nbins, a.dz, area, vp)
    hs, hl = surface(ps, a.dz), surface(pl, a.dz)
    h = min(hs, hl)
    print(f"\nwindow [{a.t0}, {a.t1}] in {len(bs)} (sweep) and {len(bl_)} (LAMMPS) blocks of "
          f"{a.block} s; bins of {a.dz} d by centre; bed height (phi at half its bulk value) "
          f"sweep {hs:.2f} d, LAMMPS {hl:.2f} d\n")
    print("## Profiles (mean of block means +- standard error)\n")
    rho = float(next(l.split()[3] for l in data.split("Atoms # sphere")[1].splitlines()
                     if l.strip() and l.split()[1] == "1"))
    obs = observer_profile(a.db)
    print("| z/d | V_x sweep | V_x LAMMPS | rel. diff | phi sweep | phi LAMMPS | diff | "
          "sweep observer V_x, phi |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    worst_v, worst_phi, fails = 0.0, 0.0, []
    for k in range(nbins):
        z = (k + 0.5) * a.dz
        if z > h + 1 or vs[k] is None or vl[k] is None:
            continue
        rel = vs[k][0] / vl[k][0] - 1.0
        rel_err = abs(vs[k][0] / vl[k][0]) * math.hypot(vs[k][1] / vs[k][0], vl[k][1] / vl[k][0])
        dphi = ps[k][0] - pl[k][0]
        dphi_err = math.hypot(ps[k][1], pl[k][1])
        in_v = 4.0 <= z <= h - 1.0
        in_phi = 4.0 <= z <= h - 4.0
        if in_v:
            worst_v = max(worst_v, abs(rel))
            if abs(rel) > a.tol_v:
                fails.append(f"V_x at z = {z} d: {rel:+.3f} (+- {rel_err:.3f})")
        if in_phi:
            worst_phi = max(worst_phi, abs(dphi))
            if abs(dphi) > a.tol_phi:
                fails.append(f"phi at z = {z} d: {dphi:+.3f} (+- {dphi_err:.3f})")
        mark = ("V" if in_v else "") + ("phi" if in_phi else "")
        print(f"| {z:.1f} {mark} | {vs[k][0]:.3f} +- {vs[k][1]:.3f} | {vl[k][0]:.3f} +- "
              f"{vl[k][1]:.3f} | {rel:+.3f} +- {rel_err:.3f} | {ps[k][0]:.3f} +- {ps[k][1]:.3f} | "
              f"{pl[k][0]:.3f} +- {pl[k][1]:.3f} | {dphi:+.3f} | {interpolate(obs, z, 2):.3f}, "
              f"{interpolate(obs, z, 1) / rho:.3f} |")
    # Surface velocity: V_x of the bin one d below the lower of the two bed heights.
    ks = int(math.floor((h - 1.0) / a.dz))
    us, ul = vs[ks], vl[ks]
    print(f"\n## Summary\n")
    print("| quantity | sweep | LAMMPS | difference | target |\n|---|---:|---:|---:|---|")
    print(f"| KE in [{a.t0}, {a.t1}] | {ke_s[0]:.0f} +- {ke_s[1]:.0f} | {ke_l[0]:.0f} +- "
          f"{ke_l[1]:.0f} | {ke_s[0] / ke_l[0] - 1:+.3f} | |")
    def fmt(tr):
        return "n/a (fewer than 3 blocks)" if tr is None else f"{tr[0]:+.3f} +- {tr[1]:.3f}"
    trend_s, trend_l = fmt(trend(es, a.t0, a.t1, a.block)), fmt(trend(el, a.t0, a.t1, a.block))
    print(f"| KE trend x window / mean | {trend_s} | {trend_l} | | |")
    print(f"| surface V_x (z = {(ks + 0.5) * a.dz:.1f} d) | {us[0]:.3f} +- {us[1]:.3f} | "
          f"{ul[0]:.3f} +- {ul[1]:.3f} | {us[0] / ul[0] - 1:+.3f} | |")
    print(f"| bed height h (d) | {hs:.2f} | {hl:.2f} | {hs - hl:+.2f} | |")
    print(f"| max abs V_x diff, 4 d <= z <= h - 1 d | | | {worst_v:.3f} | <= {a.tol_v} |")
    print(f"| max abs phi diff, 4 d <= z <= h - 4 d | | | {worst_phi:.3f} | <= {a.tol_phi} |")
    if fails:
        print("\nFAIL: " + "; ".join(fails))
        return 1
    print("\nPASS")
    return 0


if __name__ == "__main__":
    sys.exit(main())
