#!/usr/bin/env python3
"""Converts a NOAA World Magnetic Model coefficient file (WMM.COF) into the two files
GeographicLib's MagneticModel reads: <name>.wmm (text metadata) and <name>.wmm.cof (binary
coefficients).

    python3 tools/wmm_cof_to_geographiclib.py WMM.COF avsp_sensors/data/magnetic --name wmm2025

The input is NOAA/NCEI's distribution format (public domain): a header line
"<epoch> <model name> <release date MM/DD/YYYY>", then one line per degree n and order m,
"n m g h g_dot h_dot" (nT and nT/year, Schmidt semi-normalised), ended by a line of 9s.

The output follows GeographicLib's documented magnetic model format (MagneticModel.hpp and the
"Magnetic models" page of its manual):

- <name>.wmm: first line "WMMF-2", then "Key Value" lines (Name, Description, URL, Publisher,
  ReleaseDate, DataVersion, Radius, NumModels, Epoch, DeltaEpoch, MinTime,
  MaxTime, MinHeight, MaxHeight, Normalization, ByteOrder, ID).
- <name>.wmm.cof: the 8-character ID, then NumModels + 1 coefficient sets (here: the main field
  at Epoch, then its secular variation per year). Each set is N and M as little-endian int32,
  then C[n][m] (= g) for m = 0..M, n = m..N, then S[n][m] (= h) for m = 1..M, n = m..N, as
  little-endian float64 (column-major, GeographicLib's SphericalEngine layout). The degree-0 term
  C[0][0] is 0 (a magnetic field has no monopole).

Validity written into the metadata: the WMM is valid for five years from its epoch
(MinTime = epoch, MaxTime = epoch + 5) and from 1 km below to 850 km above the WGS-84 ellipsoid
(the WMM2025 technical report's stated range), with reference radius 6371200 m.
"""
import argparse
import datetime
import math
import os
import struct
import sys

REFERENCE_RADIUS_M = 6371200.0  # the WMM's geomagnetic reference radius a
VALID_YEARS = 5.0
MIN_HEIGHT_M = -1000.0
MAX_HEIGHT_M = 850000.0


class CofError(Exception):
    pass


def read_cof(path):
    """Returns (epoch, model name, release date as YYYY-MM-DD, {(n, m): (g, h, gdot, hdot)})."""
    with open(path, encoding="ascii") as f:
        lines = [line.strip() for line in f]
    lines = [line for line in lines if line]
    if not lines:
        raise CofError(f"{path}: empty file")
    head = lines[0].split()
    if len(head) != 3:
        raise CofError(f"{path}: line 1 must be '<epoch> <model> <MM/DD/YYYY>' (got {lines[0]!r})")
    try:
        epoch = float(head[0])
        release = datetime.datetime.strptime(head[2], "%m/%d/%Y").date().isoformat()
    except ValueError as e:
        raise CofError(f"{path}: line 1: {e}") from e
    terms = {}
    for number, line in enumerate(lines[1:], start=2):
        if set(line) == {"9"}:
            break
        fields = line.split()
        if len(fields) != 6:
            raise CofError(f"{path}: line {number}: expected 'n m g h g_dot h_dot' (got {line!r})")
        n, m = int(fields[0]), int(fields[1])
        values = tuple(float(x) for x in fields[2:])
        if not (1 <= n and 0 <= m <= n) or not all(math.isfinite(v) for v in values):
            raise CofError(f"{path}: line {number}: bad degree/order or value ({line!r})")
        if (n, m) in terms:
            raise CofError(f"{path}: line {number}: degree {n} order {m} given twice")
        if m == 0 and (values[1] != 0.0 or values[3] != 0.0):
            raise CofError(f"{path}: line {number}: h of order 0 must be 0")
        terms[(n, m)] = values
    else:
        raise CofError(f"{path}: no end line of 9s")
    degree = max(n for n, _ in terms)
    missing = [(n, m) for n in range(1, degree + 1) for m in range(n + 1) if (n, m) not in terms]
    if missing:
        raise CofError(f"{path}: missing terms (n, m) {missing[:5]}")
    return epoch, head[1], release, degree, terms


def coefficient_set(terms, degree, g_index, h_index):
    """One GeographicLib coefficient set: N, M, then C column-major from m = 0, then S from m = 1."""
    c, s = [], []
    for m in range(degree + 1):
        for n in range(m, degree + 1):
            c.append(0.0 if n == 0 else terms[(n, m)][g_index])
    for m in range(1, degree + 1):
        for n in range(m, degree + 1):
            s.append(terms[(n, m)][h_index])
    return struct.pack("<2i", degree, degree) + struct.pack(f"<{len(c)}d", *c) + struct.pack(f"<{len(s)}d", *s)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("cof", help="NOAA WMM.COF")
    parser.add_argument("out_dir", help="folder for <name>.wmm and <name>.wmm.cof")
    parser.add_argument("--name", default="wmm2025", help="model name (file stem), default wmm2025")
    parser.add_argument("--source", default="WMM.COF of NOAA NCEI's WMM2025 release (wmm-calculator 1.4.4 on PyPI)",
                        help="where the WMM.COF came from (written into the metadata comments)")
    args = parser.parse_args()
    try:
        epoch, model, release, degree, terms = read_cof(args.cof)
    except (OSError, CofError) as e:
        sys.exit(f"wmm_cof_to_geographiclib: {e}")
    ident = model.replace("-", "")[:7].ljust(7, "_") + "A"  # 8 characters, e.g. WMM2025A
    os.makedirs(args.out_dir, exist_ok=True)
    cof_path = os.path.join(args.out_dir, args.name + ".wmm.cof")
    with open(cof_path, "wb") as f:
        f.write(ident.encode("ascii"))
        f.write(coefficient_set(terms, degree, 0, 1))  # main field at the epoch, nT
        f.write(coefficient_set(terms, degree, 2, 3))  # secular variation, nT/year
    meta = [
        "WMMF-2",
        "# GeographicLib magnetic model metadata (format: GeographicLib's MagneticModel",
        "# documentation). Written by tools/wmm_cof_to_geographiclib.py from the",
        f"# {args.source}.",
        "# The coefficients (NOAA NCEI and the British Geological Survey; public domain) are in the",
        "# file of the same name ending .cof: the main field at Epoch, then its secular",
        "# variation per year; the model is linear in time over [MinTime, MaxTime].",
        f"Name            {args.name}",
        f"Description     World Magnetic Model {model.split('-')[-1]}",
        "URL             https://www.ncei.noaa.gov/products/world-magnetic-model",
        "Publisher       National Oceanic and Atmospheric Administration",
        f"ReleaseDate     {release}",
        "DataVersion     1",
        f"Radius          {REFERENCE_RADIUS_M:.0f}",
        "NumModels       1",
        f"Epoch           {epoch:g}",
        f"DeltaEpoch      {VALID_YEARS:g}",
        f"MinTime         {epoch:g}",
        f"MaxTime         {epoch + VALID_YEARS:g}",
        f"MinHeight       {MIN_HEIGHT_M:.0f}",
        f"MaxHeight       {MAX_HEIGHT_M:.0f}",
        "Normalization   Schmidt",
        "ByteOrder       Little",
        f"ID              {ident}",
    ]
    with open(os.path.join(args.out_dir, args.name + ".wmm"), "w", encoding="ascii") as f:
        f.write("\n".join(meta) + "\n")
    print(f"wrote {args.name}.wmm and {args.name}.wmm.cof (degree {degree}, epoch {epoch:g}) in {args.out_dir}")


if __name__ == "__main__":
    main()
