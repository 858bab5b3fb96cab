#!/usr/bin/env python3
"""Writes the small hand-made seed corpora of fuzz/corpus (except the ONNX models, which
make_seed_onnx writes). Deterministic; rerun after changing it and commit the output.
Usage: fuzz/make_seeds.py   (from anywhere)"""
import gzip
import os
import struct

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus")


def put(harness, name, data):
    d = os.path.join(ROOT, harness)
    os.makedirs(d, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


# --- fuzz_csv: valid tables, comments/blank lines/CRLF, and a few near-misses.
put("fuzz_csv", "small.csv", "1,2,3\n4,5,6\n")
put("fuzz_csv", "comments_crlf.csv", "# header comment\r\n\r\n  1.5 , -2e-3\r\n\t3,4\r\n# end\r\n")
put("fuzz_csv", "column.csv", "0.1\n0.2\n0.3\n1e308\n-1e-300\n")
put("fuzz_csv", "ragged.csv", "1,2\n3\n")
put("fuzz_csv", "bad_cell.csv", "1,x\n")
put("fuzz_csv", "conductances.csv",
    "\n".join(",".join("%.6g" % (3.3e-6 + 1e-6 * ((r * 7 + c * 3) % 60)) for c in range(8)) for r in range(8)) + "\n")

# --- fuzz_config: first line is also used as a --set assignment.
put("fuzz_config", "set_vectors.yaml", "study.vectors=10\n")
put("fuzz_config", "set_list.yaml", "converters.adc_bits=[4, 6, 8]\n")
put("fuzz_config", "paper.yaml", """mapping.max_rows=unbounded
crossbar:
  r_wire: 1.0
  r_in: 1.0
  r_out: 1.0
  g_min: 3.3333333333333333e-6
  g_max: 6.6666666666666667e-5
  v_in_max: 0.4
mapping:
  max_rows: unbounded
  max_cols: unbounded
  negative: shift
  g_headroom: 0.0
mitigation:
  method: conversion+calibration
conversion:
  signal: constant
  amplitude: paper
calibration:
  samples: 10
  signal: shuffled
converters:
  dac_bits: none
  adc_bits: none
""")
put("fuzz_config", "sweep.yaml", """solver.tolerance=1e-9
study:
  rows: [64, 128, 256]
  vectors: 100
solver: {method: line, tolerance: 1.0e-10, max_iterations: 500}
mapping:
  max_rows: 144
""")
put("fuzz_config", "bad.yaml", "crossbar:\n  r_wire: [1, {a: 2}]\n  nosuch: 3\n")
put("fuzz_config", "anchors.yaml", "x: &a {r_wire: 2}\ncrossbar: *a\n? [study]\n: 1\n")

# --- fuzz_dataset: byte 0 even = CIFAR-10 file; odd = MNIST with a 2-byte images length.
def cifar_record(label):
    return bytes([label]) + bytes((label * 31 + i) & 0xFF for i in range(3072))


put("fuzz_dataset", "cifar_one.bin", b"\x00" + cifar_record(3))
put("fuzz_dataset", "cifar_truncated.bin", b"\x00" + cifar_record(7)[:1500])


def mnist(n, rows, cols):
    im = struct.pack(">IIII", 2051, n, rows, cols) + bytes((i * 13) & 0xFF for i in range(n * rows * cols))
    lb = struct.pack(">II", 2049, n) + bytes(i % 10 for i in range(n))
    return im, lb


def mnist_seed(im, lb):
    return b"\x01" + struct.pack("<H", len(im)) + im + lb


im, lb = mnist(2, 4, 4)
put("fuzz_dataset", "mnist_plain.bin", mnist_seed(im, lb))
im, lb = mnist(3, 5, 3)
put("fuzz_dataset", "mnist_gzip.bin", mnist_seed(gzip.compress(im, mtime=0), gzip.compress(lb, mtime=0)))
im, lb = mnist(2, 4, 4)
put("fuzz_dataset", "mnist_short.bin", mnist_seed(im[:30], lb))
