"""Sweep the ADC resolution of the built-in ResNet-20 on the platform and plot energy per image
(matplotlib if present, else a table).

    PYTHONPATH=build/python /usr/bin/python3 examples/python/sweep_adc_bits.py
"""
import xbarsim

rows = []
for bits in (4, 6, 8):
    r = xbarsim.simulate(preset="resnet20", timing_only=True, overrides={"converters.adc_bits": bits})
    rows.append((bits, r["energy_uj_per_image"], r["throughput_images_per_s"], r["area_mm2"]))
    print(f"ADC {bits} bits: {rows[-1][1]:8.2f} uJ/image, {rows[-1][2]:8.0f} images/s, {rows[-1][3]:7.2f} mm2")
try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print("(matplotlib not installed: no plot)")
else:
    plt.plot([b for b, *_ in rows], [e for _, e, *_ in rows], marker="o")
    plt.xlabel("ADC bits")
    plt.ylabel("energy per image (uJ)")
    plt.savefig("adc_bits.png", dpi=120)
    print("wrote adc_bits.png")
