"""Solve one crossbar's exact circuit from Python and compare it with the ideal product G^T V.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/solve_crossbar.py
"""
import numpy as np

import xbarsim

rng = np.random.default_rng(0)
rows, cols = 128, 64
G = rng.uniform(1e-6, 1e-4, size=(rows, cols))  # siemens, within crossbar.g_min .. g_max
V = rng.uniform(0.0, 0.3, size=(16, rows))  # one input vector (volts) per row of V

for r_wire in (0.1, 1.0, 2.5):
    cfg = xbarsim.Config(overrides={"crossbar.r_wire": r_wire})
    I = xbarsim.solve(G, V, cfg)  # amperes, 16 x 64
    ideal = V @ G
    err = np.abs(I - ideal).max() / np.abs(ideal).max()
    print(f"r_wire = {r_wire:3.1f} ohm: worst deviation from G^T V = {100 * err:6.3f} % of full scale")
