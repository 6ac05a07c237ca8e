#!/usr/bin/env python3
"""Prints the 2^(k/128) table of the vectorised exp in src/rmp/collision_leaf_simd.cc.

Entry k (k = 0..127) is a pair: the bits of tail_k = (2^(k/128) - H_k) / H_k rounded to double, and the bits of
H_k = 2^(k/128) rounded to double minus k << 45 (so that adding the exponent bits of n·128 + k gives 2^n · H_k).
Computed with 60 decimal digits, then rounded once: the C library's exp (glibc) uses this table, and the kernel
must return its results bit for bit.
"""
import struct
from decimal import Decimal, getcontext

getcontext().prec = 60


def bits(x: float) -> int:
    return struct.unpack("<Q", struct.pack("<d", x))[0]


ln2 = Decimal(2).ln()
words = []
for k in range(128):
    exact = (Decimal(k) / 128 * ln2).exp()
    head = float(exact)  # correctly rounded
    tail = float((exact - Decimal(head)) / Decimal(head))
    words += [bits(tail), (bits(head) - (k << 45)) % 2**64]
for i in range(0, len(words), 4):
    print("    " + ", ".join(f"0x{w:016x}" for w in words[i:i + 4]) + ",")
