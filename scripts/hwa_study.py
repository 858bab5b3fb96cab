#!/usr/bin/env python3
"""Issue 41's study: what hardware-aware fine-tuning gains on the exact circuit (docs/results.md,
"Hardware-aware training"). Trains with `python3 -m xbarsim.hwa` and evaluates with `xbarsim eval`;
resumable (a model or result already in OUT is kept). Long: about an hour on 2 cores.

    PYTHONPATH=build/python /usr/bin/python3 scripts/hwa_study.py OUT [--data ../shared/data]
        [--images 2000] [--headline 10000] [--stages b1,devices,grid,headline]

Stages:
  b1        one HWA epoch over data_batch_1 under rram-wan2022 (differential pairs), against the
            original on 1000 test images at t = 1 s (the issue's first target);
  devices   HWA on the 20 000 training images under rram-wan2022 and under pcm-joshi2020 (global
            compensation, times drawn log-uniformly in 1 s .. 1 year), each against the original at
            t = 1 s, 1 day, 1 year on --images test images;
  grid      NeuRRAM's form: training noise 0 (the original) / 0.1 / 0.2 of each layer's largest
            |weight| x inference noise 0 / 0.05 / 0.10 / 0.15 of it (a device model file of constant
            programming spread on 20-70 uS, so no cell is clipped at g_min);
  headline  the rram-wan2022 models at t = 1 s on --headline test images.
"""
import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
DIFF = ["--set", "mapping.negative=differential"]


def sh(argv, log):
    start = time.monotonic()
    with open(log, "w") as f:
        r = subprocess.run(argv, stdout=f, stderr=subprocess.STDOUT)
    if r.returncode != 0:
        sys.exit(f"hwa_study: {' '.join(map(str, argv))} failed (exit {r.returncode}); see {log}")
    return time.monotonic() - start


class Study:
    def __init__(self, args):
        self.out = os.path.abspath(args.out)
        os.makedirs(self.out, exist_ok=True)
        self.data = os.path.abspath(args.data)
        self.xbarsim = os.path.abspath(args.xbarsim)
        self.images, self.headline = args.images, args.headline
        self.original = os.path.join(self.data, os.pardir, "models", "resnet20_cifar10.onnx")
        self.times = {}
        for name, files in (("train1", ["data_batch_1.bin"]), ("train", ["data_batch_1.bin", "data_batch_2.bin"])):
            d = os.path.join(self.out, name)
            os.makedirs(d, exist_ok=True)
            for f in files + ["calib_batch.bin"]:
                link = os.path.join(d, f)
                if not os.path.exists(link):
                    os.symlink(os.path.join(self.data, "cifar10", f), link)

    def path(self, name):
        return os.path.join(self.out, name)

    def train(self, name, train_dir, *args):
        out = self.path(name + ".onnx")
        if not os.path.exists(out):
            seconds = sh([sys.executable, "-m", "xbarsim.hwa", "--model", self.original, "--train",
                          self.path(train_dir), "--epochs", "1", "--out", out, *args], self.path(name + ".train.log"))
            with open(self.path(name + ".seconds"), "w") as f:
                f.write(f"{seconds:.1f}\n")
        with open(self.path(name + ".seconds")) as f:
            self.times[name] = float(f.read())
        return out

    def eval(self, tag, model, images, *args):
        out = self.path(tag + ".json")
        if not os.path.exists(out):
            sh([self.xbarsim, "eval", "--model", model, "--dataset", "cifar10", "--images", str(images), *args,
                "--json", out + ".tmp"], self.path(tag + ".eval.log"))
            os.replace(out + ".tmp", out)
        with open(out) as f:
            r = json.load(f)
        return r if isinstance(r, list) else [r]

    def b1(self):
        hwa = self.train("rram_b1", "train1", "--set", "device.model=rram-wan2022", *DIFF)
        soft = self.train("software_b1", "train1", "--software")
        rows = []
        for tag, label, model in (("original", "original", self.original),
                                  ("hwa", "HWA, 1 epoch on data_batch_1", hwa),
                                  ("software", "control: the same epoch in software (clipped, no noise)", soft)):
            r = self.eval("b1_" + tag, model, 1000, *DIFF,
                          "--set", "device.model=rram-wan2022", "--set", "device.time_s=1")[0]
            rows.append((label, r["software_accuracy"], r["crossbar_accuracy"]))
        o_sw, o_xb = rows[0][1], rows[0][2]
        print("\n## One HWA epoch over data_batch_1 (rram-wan2022, differential, t = 1 s, 1000 test images)\n")
        print("| model | software | crossbar |\n|---|---:|---:|")
        for label, sw, xb in rows:
            print(f"| {label} | {100 * sw:.1f} % | {100 * xb:.1f} % |")
        drop = o_sw - o_xb
        print(f"\noriginal drop {100 * drop:.1f} points; HWA recovers {100 * (rows[1][2] - o_xb):.1f} points = "
              f"{(rows[1][2] - o_xb) / drop:.2f} of it; training {self.times['rram_b1']:.0f} s "
              f"(software epoch {self.times['software_b1']:.0f} s)")

    def devices(self):
        models = {
            "rram-wan2022": self.train("rram", "train", "--set", "device.model=rram-wan2022", *DIFF),
            "pcm-joshi2020": self.train("pcm", "train", "--set", "device.model=pcm-joshi2020", *DIFF,
                                        "--set", "device.compensation=global", "--time", "1,3.156e7"),
        }
        control = self.train("software", "train", "--software")
        for device, hwa in models.items():
            extra = ["--set", "device.compensation=global"]
            print(f"\n## {device}, differential, global compensation ({self.images} test images)\n")
            print("| model | software | 1 s | 1 day | 1 year |\n|---|---:|---:|---:|---:|")
            for label, model in (("original", self.original), ("HWA", hwa), ("control", control)):
                runs = self.eval(f"dev_{device}_{label}", model, self.images, *DIFF, "--set", f"device.model={device}",
                                 "--set", "device.time_s=[1,86400,3.156e7]", *extra)
                cells = " | ".join(f"{100 * r['crossbar_accuracy']:.1f}" for r in runs)
                print(f"| {label} | {100 * runs[0]['software_accuracy']:.1f} | {cells} |")
        print(f"\ncontrol: the same epoch in software (clipped, no noise). Training (1 epoch, 20 000 images): "
              f"rram-wan2022 {self.times['rram']:.0f} s, pcm-joshi2020 {self.times['pcm']:.0f} s, software "
              f"{self.times['software']:.0f} s")

    def grid(self):
        noises = [0.0, 0.05, 0.10, 0.15]
        models = {"0 (original)": self.original, "0 (fine-tuned, clipped)": self.train("software", "train", "--software")}
        for f in (0.1, 0.2):
            models[str(f)] = self.train(f"neurram_{f}", "train", "--weight-noise", str(f), *DIFF)
        span_us = 70 * 0.8 - 20  # g_max (1 - g_headroom) - g_min: weights map to 20..56 uS
        print("\n## NeuRRAM's noise grid (ideal devices but for the inference noise; differential; "
              f"{self.images} test images)\n")
        print("| training noise | " + " | ".join(f"inference {n:.2f}" for n in noises) + " |")
        print("|---|" + "---:|" * len(noises))
        for label, model in models.items():
            cells = []
            for n in noises:
                device = self.noise_model(n * span_us / 2 ** 0.5)
                tag = label.split()[0] + ("c" if "clipped" in label else "")
                r = self.eval(f"grid_{tag}_{n}", model, self.images, *DIFF,
                              "--set", f"device.model={device}")[0]
                cells.append(f"{100 * r['crossbar_accuracy']:.1f}")
            print(f"| {label} | " + " | ".join(cells) + " |")

    def noise_model(self, sigma_us):
        """A device model file: a constant programming spread sigma_us (weights' N(0, f max|W|)
        with sigma = f x span / sqrt(2) per cell of a pair), 20-70 uS, no read noise, no drift."""
        path = self.path(f"noise_{sigma_us:.4f}.yaml")
        with open(path, "w") as f:
            f.write(f"""name: neurram-noise-{sigma_us:.4f}us
source: "NeuRRAM's inference noise (Wan et al. 2022, Fig. 4): Gaussian weight noise of a fraction of the layer's largest weight"
range:
  g_min_us: 20.0
  g_max_us: 70.0
programming:
  sigma_us: [{sigma_us:.6f}, 0.0, 0.0, 0.0, 0.0]
relaxation:
  times_s: [1.0]
  sigma_us:
    - [{sigma_us:.6f}, 0.0, 0.0, 0.0, 0.0]
  shift_us: [0.0]
read:
  relative: 0.0
  sqrt_relative: 0.0
  sigma_us: 0.0
clip_to_range: false
""")
        return path

    def headline_stage(self):
        rram = self.train("rram", "train", "--set", "device.model=rram-wan2022", *DIFF)
        print(f"\n## Headline: rram-wan2022, differential, t = 1 s, {self.headline} test images\n")
        print("| model | software | crossbar |\n|---|---:|---:|")
        for label, model in (("original", self.original), ("HWA", rram)):
            r = self.eval(f"headline_{label}", model, self.headline, *DIFF, "--set", "device.model=rram-wan2022",
                          "--set", "device.time_s=1")[0]
            print(f"| {label} | {100 * r['software_accuracy']:.2f} | {100 * r['crossbar_accuracy']:.2f} |")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("out")
    p.add_argument("--data", default=os.path.join(ROOT, os.pardir, "shared", "data"))
    p.add_argument("--xbarsim", default=os.path.join(ROOT, "build", "sw", "xbarsim"))
    p.add_argument("--images", type=int, default=2000)
    p.add_argument("--headline", type=int, default=10000)
    p.add_argument("--stages", default="b1,devices,grid,headline")
    args = p.parse_args()
    study = Study(args)
    for stage in args.stages.split(","):
        {"b1": study.b1, "devices": study.devices, "grid": study.grid, "headline": study.headline_stage}[stage]()
        sys.stdout.flush()


if __name__ == "__main__":
    main()
