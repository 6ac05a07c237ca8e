#!/usr/bin/env python3
"""Prints the 2^(k/128) table of the vectorised exp in src/rmp/collision_leaf_simd.cc; with --check, exits 1 unless
that file holds exactly this table.

Entry k (k = 0..127) is a pair: the bits of tail_k = (2^(k/128) - H_k) / H_k rounded to double, and the bits of
H_k = 2^(k/128) rounded to double minus k << 45 (so that adding the exponent bits of n·128 + k gives 2^n · H_k).
Computed with 60 decimal digits, then rounded once: the C library's exp (glibc) uses this table, and the kernel
must return its results bit for bit.
"""
import pathlib
import re
import struct
import sys
from decimal import Decimal, getcontext

getcontext().prec = 60


def bits(x: float) -> int:
    return struct.unpack("<Q", struct.pack("<d", x))[0]


def table() -> list[int]:
    ln2 = Decimal(2).ln()
    words = []
    for k in range(128):
        exact = (Decimal(k) / 128 * ln2).exp()
        head = float(exact)  # correctly rounded
        tail = float((exact - Decimal(head)) / Decimal(head))
        words += [bits(tail), (bits(head) - (k << 45)) % 2**64]
    return words


def main() -> int:
    words = table()
    if sys.argv[1:] == ["--check"]:
        source = pathlib.Path(__file__).resolve().parent.parent / "src" / "rmp" / "collision_leaf_simd.cc"
        body = re.search(r"kExpTable\[256\] = \{(.*?)\};", source.read_text(), re.S)
        found = [int(w, 16) for w in re.findall(r"0x[0-9a-f]{16}", body.group(1))] if body else []
        if found != words:
            print(f"{source}: kExpTable differs from the table this script computes", file=sys.stderr)
            return 1
        print("kExpTable: the 256 words this script computes")
        return 0
    for i in range(0, len(words), 4):
        print("    " + ", ".join(f"0x{w:016x}" for w in words[i:i + 4]) + ",")
    return 0


if __name__ == "__main__":
    sys.exit(main())
