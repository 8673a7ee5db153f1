"""Writes agv_rtk.nmea: what a dual-antenna RTK receiver on an AGV sends at
10 Hz — 20 s standing, then 30 s driving north-east at 1 m/s — as GGA (RTK
fixed), RMC, GST and HDT, with the checksums a receiver computes.

Run from this directory: python3 generate.py (deterministic; committed output).
"""

import math

START_LAT, START_LON, ALT = 29.1330, 119.6400, 40.0
HEADING_DEG = 45.0
RATE_HZ = 10
EARTH_R = 6378137.0


def checksum(body):
    c = 0
    for ch in body.encode():
        c ^= ch
    return f"{c:02X}"


def sentence(body):
    return f"${body}*{checksum(body)}\r\n"


def angle(value, deg_digits, hemis):
    hemi = hemis[0] if value >= 0 else hemis[1]
    value = abs(value)
    deg = int(value)
    minutes = (value - deg) * 60.0
    return f"{deg:0{deg_digits}d}{minutes:011.8f}", hemi


def main():
    lines = []
    north = east = 0.0
    for k in range(50 * RATE_HZ):
        t = k / RATE_HZ
        speed = 0.0 if t < 20.0 else 1.0
        if k > 0 and speed > 0:
            north += speed / RATE_HZ * math.cos(math.radians(HEADING_DEG))
            east += speed / RATE_HZ * math.sin(math.radians(HEADING_DEG))
        lat = START_LAT + math.degrees(north / EARTH_R)
        lon = START_LON + math.degrees(east / (EARTH_R * math.cos(math.radians(START_LAT))))
        secs = 10 * 3600 + t
        hh, mm, ss = int(secs // 3600), int(secs % 3600 // 60), secs % 60
        utc = f"{hh:02d}{mm:02d}{ss:05.2f}"
        la, ns = angle(lat, 2, "NS")
        lo, ew = angle(lon, 3, "EW")
        lines.append(sentence(f"GNGGA,{utc},{la},{ns},{lo},{ew},4,24,0.6,{ALT:.3f},M,0.000,M,1.0,0000"))
        knots = speed / 0.514444
        lines.append(sentence(f"GNRMC,{utc},A,{la},{ns},{lo},{ew},{knots:.3f},{HEADING_DEG:.2f},211126,,,R,V"))
        lines.append(sentence(f"GNGST,{utc},0.012,0.010,0.008,0.0,0.010,0.010,0.020"))
        lines.append(sentence(f"GNHDT,{HEADING_DEG:.2f},T"))
    with open("agv_rtk.nmea", "w", newline="") as f:
        f.writelines(lines)


if __name__ == "__main__":
    main()
