#!/usr/bin/env python3
"""How far up a silo's bed the rotating bottom turns it: ω(z)/Ω from a campaign's fields.

Reads each job's time-averaged `mean` field set (the `fields` observer: an r-z grid, velocity
components r, θ, z) and, per height band above the bottom, averages the angular velocity
V_θ/r over the packed cells (φ > 0.3) at mid radius (0.3 R_c < r < 0.9 R_c, away from the
orifice's stream and the wall's shear layer), divided by the bottom's Ω = 2π f. 1 means the
bed turns with the bottom as a solid; 0 means it stands still. Replicas of one (D, f) are
averaged. Jobs at f = 0 are skipped.

usage: silo_spin.py DB CAMPAIGN [--d-mm D] [--band-mm 10]
prints one markdown table: rows = height bands (mm above the bottom), columns = (D, f).
"""
import argparse
import json
import math
import sqlite3
import struct
import sys


def field(conn, set_id, name):
    row = conn.execute(
        "SELECT components, data FROM field_arrays WHERE set_id = ? AND field = ?",
        (set_id, name),
    ).fetchone()
    if row is None:
        return None, 0
    comps, blob = row
    return struct.unpack("<%dd" % (len(blob) // 8), blob), comps


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("db")
    ap.add_argument("campaign")
    ap.add_argument("--d-mm", type=float, help="only this orifice diameter (mm)")
    ap.add_argument("--band-mm", type=float, default=10.0)
    a = ap.parse_args()
    conn = sqlite3.connect("file:%s?mode=ro" % a.db, uri=True)
    cid = conn.execute(
        "SELECT id FROM campaigns WHERE name = ? ORDER BY version DESC LIMIT 1", (a.campaign,)
    ).fetchone()
    if cid is None:
        sys.exit("%s: no campaign named %r" % (a.db, a.campaign))
    rows = conn.execute(
        """SELECT fs.id, fs.grid_json, j.params_json FROM field_sets fs
           JOIN campaign_jobs cj ON cj.job_id = fs.job_id JOIN jobs j ON j.id = fs.job_id
           WHERE cj.campaign_id = ? AND fs.name = 'mean' AND j.status = 'done'""",
        (cid[0],),
    ).fetchall()
    bands = {}  # (d_mm, f) -> {band: [sum, n]}
    for set_id, grid_json, params_json in rows:
        p = json.loads(params_json)["silo"]
        f = p["rotation_frequency_hz"]
        d_mm = round(p["orifice_diameter_m"] * 1e3, 1)
        if f == 0 or (a.d_mm is not None and abs(d_mm - a.d_mm) > 0.05):
            continue
        rc = p["cylinder_radius_m"]
        g = json.loads(grid_json)
        (r0, z0, _), (dr, dz, _), (nr, nz, _) = g["origin_m"], g["spacing_m"], g["shape"]
        v, vc = field(conn, set_id, "velocity")
        phi, _ = field(conn, set_id, "phi")
        if v is None or phi is None:
            continue
        omega = 2 * math.pi * f
        acc = bands.setdefault((d_mm, f), {})
        for k in range(nz):
            z = z0 + k * dz
            if z < 0:
                continue
            band = int(z * 1e3 // a.band_mm)
            for i in range(nr):
                r = r0 + i * dr
                idx = k * nr + i
                if not (0.3 * rc < r < 0.9 * rc) or phi[idx] <= 0.3:
                    continue
                s = acc.setdefault(band, [0.0, 0])
                s[0] += v[idx * vc + 1] / r / omega
                s[1] += 1
    if not bands:
        sys.exit("%s: campaign %r has no done job with a mean field at f > 0" % (a.db, a.campaign))
    keys = sorted(bands)
    top = max(b for k in keys for b in bands[k])
    print("| z above the bottom (mm) | " + " | ".join("D = %g mm, f = %g Hz" % k for k in keys) + " |")
    print("|---" * (len(keys) + 1) + "|")
    for b in range(top + 1):
        cells = []
        for k in keys:
            s = bands[k].get(b)
            cells.append("%.2f" % (s[0] / s[1]) if s and s[1] else "")
        if any(cells):
            print("| %g–%g | %s |" % (b * a.band_mm, (b + 1) * a.band_mm, " | ".join(cells)))


if __name__ == "__main__":
    main()
