"""Hardware-aware fine-tuning of an ONNX model, for `xbarsim eval` to check on the exact circuit.

    python3 -m xbarsim.hwa --model M.onnx --train DIR --epochs N [--config F] [--set key=value]... --out OUT.onnx

fine-tunes M with the configuration's device model and converters in the forward (xbarsim.nn's
fast training path) on DIR's CIFAR-10 training batches and writes OUT: the same graph with the
fine-tuned weights and M's preprocessing metadata. From Python: fine_tune(model, hardware, data).
"""
import argparse
import math
import os
import signal
import sys
import time

import numpy as np
import torch
import torch.nn.functional as F

from . import Config
from . import data as _data
from . import nn as _nn
from . import onnx as _onnx

__all__ = ["fine_tune", "clip_weights", "main"]


def _clock(seconds):
    seconds = int(round(seconds))
    h, rest = divmod(seconds, 3600)
    m, s = divmod(rest, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


def clip_weights(model, sigmas):
    """Clamps every Conv2d/Linear weight of `model` to +-sigmas x the standard deviation of its
    layer's weights (aihwkit's layer-Gaussian clipping): a crossbar's conductance scale is set by
    its largest |weight|, so an outlier squeezes every other weight into a sliver of the range and
    under the device's noise (docs/python.md). 0: no clipping."""
    if sigmas <= 0:
        return
    with torch.no_grad():
        for m in model.modules():
            if isinstance(m, (torch.nn.Conv2d, torch.nn.Linear)):
                bound = float(sigmas * m.weight.std())
                m.weight.clamp_(-bound, bound)


def fine_tune(model, hardware, train, epochs=1, batch_size=128, lr=1e-4, optimizer="adam", momentum=0.9,
              weight_decay=0.0, clip_sigma=3.0, calibration=None, progress=None, seed=0):
    """Fine-tunes `model` (a module with xbarsim.nn analog layers, or a plain one: trained in
    software) on `train` (an xbarsim.data.Cifar10 set) for `epochs` epochs: Adam (or SGD with
    momentum), the learning rate `lr` decayed to 0 over the run by a cosine, cross-entropy loss,
    the weights clipped to +-clip_sigma standard deviations of their layer before training and
    after every step (clip_weights; 0: none). Every batch
    draws the hardware's programming error, faults, drift (hardware.new_batch()); every epoch
    starts by calibrating the DAC and ADC ranges on `calibration` (a batch of inputs; default the
    first 200 training images, not augmented). `progress(text)` gets a line about every 10 % of
    an epoch. Returns a list of per-epoch (loss, training accuracy)."""
    torch.manual_seed(seed)
    analog = _nn.analog_layers(model)
    if hardware is None and analog:
        hardware = analog[0].hw
    params = [p for p in model.parameters() if p.requires_grad]
    if optimizer == "adam":
        opt = torch.optim.Adam(params, lr=lr, weight_decay=weight_decay)
    elif optimizer == "sgd":
        opt = torch.optim.SGD(params, lr=lr, momentum=momentum, weight_decay=weight_decay)
    else:
        raise ValueError(f"optimizer must be adam or sgd, got {optimizer}")
    clip_weights(model, clip_sigma)
    steps_per_epoch = math.ceil(len(train) / batch_size)
    total = epochs * steps_per_epoch
    sched = torch.optim.lr_scheduler.LambdaLR(opt, lambda k: 0.5 * (1 + math.cos(math.pi * k / total)))
    if calibration is None:
        calibration = train.preprocess(train.images[:200])
    start = time.monotonic()
    history = []
    step = 0
    for epoch in range(epochs):
        if analog:
            _nn.calibrate(model, calibration)
        model.train()
        seen, correct, loss_sum = 0, 0, 0.0
        next_report = 0.1
        for x, y in train.batches(batch_size, epoch=epoch):
            if hardware is not None:
                hardware.new_batch()
            out = model(x)
            loss = F.cross_entropy(out, y)
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            sched.step()
            clip_weights(model, clip_sigma)
            step += 1
            seen += len(y)
            correct += int((out.detach().argmax(1) == y).sum())
            loss_sum += float(loss) * len(y)
            done = step / total
            if progress is not None and (seen >= next_report * len(train) or seen == len(train)):
                next_report += 0.1
                elapsed = time.monotonic() - start
                progress(f"epoch {epoch + 1}/{epochs}  {seen}/{len(train)} images  loss {loss_sum / seen:.4f}  "
                         f"train acc {100 * correct / seen:.1f} %  elapsed {_clock(elapsed)}  "
                         f"left {_clock(elapsed * (1 - done) / done)}")
        history.append((loss_sum / seen, correct / seen))
    model.eval()
    return history


class _Usage(Exception):
    pass


def _parser():
    p = argparse.ArgumentParser(
        prog="python3 -m xbarsim.hwa",
        description="Hardware-aware fine-tuning: trains an ONNX model with the configuration's device model "
                    "(device.*: programming error, stuck cells, drift at device.time_s, read noise) and converters "
                    "(DAC/ADC bits and ranges) in the forward pass, on CIFAR-10 training batches, and writes the "
                    "fine-tuned model as ONNX (the same graph and preprocessing metadata) for `xbarsim eval`. "
                    "docs/python.md, hardware-aware training, says what the training forward models.",
        epilog="Exit status: 0 done, 2 bad input (one message), 130 interrupted (no output written).")
    p.add_argument("--model", required=True, metavar="M.onnx", help="the ONNX model to fine-tune")
    p.add_argument("--train", required=True, metavar="DIR",
                   help="directory of CIFAR-10 binary training batches (data_batch_*.bin; calib_batch.bin, if there, "
                        "sets the DAC/ADC ranges, else the first 200 training images)")
    p.add_argument("--epochs", type=int, required=True, metavar="N", help="passes over the training images (>= 1)")
    p.add_argument("--out", required=True, metavar="OUT.onnx",
                   help="where the fine-tuned model is written (whole, or not at all when interrupted)")
    p.add_argument("--config", metavar="F", help="xbarsim configuration YAML (as for xbarsim eval)")
    p.add_argument("--set", action="append", default=[], metavar="key=value",
                   help="override one configuration key (repeatable), e.g. --set device.model=rram-wan2022")
    p.add_argument("--weight-noise", type=float, default=0.0, metavar="F",
                   help="NeuRRAM's training noise: Gaussian weight noise of F x each layer's largest |weight|, "
                        "drawn per batch, on top of the device model (default 0)")
    p.add_argument("--noise-scale", type=float, default=1.0, metavar="F",
                   help="train with the device's deviations (programming error, drift, read noise) times F "
                        "(default 1)")
    p.add_argument("--time", metavar="T|T0,T1",
                   help="seconds after programming each batch reads at: T, or T0,T1 drawn log-uniformly per batch "
                        "(default device.time_s)")
    p.add_argument("--batch-size", type=int, default=128, metavar="B", help="images per batch (default 128)")
    p.add_argument("--optimizer", choices=("adam", "sgd"), default="adam", help="adam (default) or sgd (with momentum)")
    p.add_argument("--lr", type=float, default=1e-4,
                   help="initial learning rate, cosine-decayed to 0 (default 1e-4, for Adam; the shared models have "
                        "their batch norms folded, and SGD above 1e-3 diverges)")
    p.add_argument("--momentum", type=float, default=0.9, help="SGD momentum (default 0.9)")
    p.add_argument("--clip-sigma", type=float, default=3.0, metavar="C",
                   help="clip every layer's weights to +-C standard deviations of the layer before and after every "
                        "step (default 3; 0: none): a crossbar's scale is its largest |weight|, so outliers cost "
                        "every other weight range and noise margin")
    p.add_argument("--weight-decay", type=float, default=0.0, help="SGD weight decay (default 0)")
    p.add_argument("--images", type=int, metavar="N", help="use only the first N training images")
    p.add_argument("--seed", type=int, default=0, help="seed of the shuffling, augmentation and every draw (default 0)")
    p.add_argument("--threads", type=int, default=0, help="torch threads (default 0: every core)")
    p.add_argument("--software", action="store_true",
                   help="fine-tune in software (no device, no converters): the noiseless reference")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    return p


def _config(args):
    overrides = {}
    for item in args.set:
        key, eq, value = item.partition("=")
        if not eq or not key:
            raise _Usage(f"--set '{item}': expected key=value")
        overrides[key.strip()] = value.strip()
    if args.config is not None and not os.path.isfile(args.config):
        raise _Usage(f"--config {args.config}: no such file")
    try:
        cfg = Config(args.config, overrides)
    except ValueError as e:
        raise _Usage(str(e)) from None
    if cfg.sweep_points() != 1:
        raise _Usage("the configuration holds a list (a sweep): hwa trains one configuration")
    return cfg


def _times(text):
    if text is None:
        return None
    try:
        parts = [float(v) for v in text.split(",")]
    except ValueError:
        raise _Usage(f"--time '{text}': expected seconds T or T0,T1") from None
    if len(parts) not in (1, 2):
        raise _Usage(f"--time '{text}': expected seconds T or T0,T1")
    return parts[0] if len(parts) == 1 else tuple(parts)


def _run(args, say):
    for name, value, low in (("--epochs", args.epochs, 1), ("--batch-size", args.batch_size, 1),
                             ("--threads", args.threads, 0)):
        if value < low:
            raise _Usage(f"{name} must be >= {low}, got {value}")
    if args.images is not None and args.images < 1:
        raise _Usage(f"--images must be >= 1, got {args.images}")
    if not (args.lr > 0 and math.isfinite(args.lr)):
        raise _Usage(f"--lr must be a number > 0, got {args.lr}")
    if not (args.clip_sigma >= 0 and math.isfinite(args.clip_sigma)):
        raise _Usage(f"--clip-sigma must be a number >= 0, got {args.clip_sigma}")
    out_dir = os.path.dirname(os.path.abspath(args.out))
    if not os.path.isdir(out_dir):
        raise _Usage(f"--out {args.out}: the directory {out_dir} does not exist")
    if os.path.abspath(args.out) == os.path.abspath(args.model):
        raise _Usage("--out names the input model: write the fine-tuned model to another file")
    cfg = _config(args)
    try:
        model = _onnx.load(args.model)
        preprocessing = model.preprocessing
        train = _data.Cifar10(args.train, train=True, preprocessing=preprocessing, limit=args.images, seed=args.seed)
        calib_file = os.path.join(args.train, "calib_batch.bin")
        calibration = None
        if os.path.isfile(calib_file):
            calib = _data.Cifar10(files=[calib_file], train=False, preprocessing=preprocessing, limit=200)
            calibration = calib.preprocess(calib.images)
        hardware = None if args.software else _nn.Hardware(cfg, weight_noise=args.weight_noise,
                                                             time_s=_times(args.time), seed=args.seed,
                                                             noise_scale=args.noise_scale)
    except ValueError as e:
        raise _Usage(str(e)) from None
    if calibration is None:
        calibration = train.preprocess(train.images[:200])
    torch.set_num_threads(args.threads or os.cpu_count() or 1)
    net = model if hardware is None else _nn.convert(model, hardware, calibration=calibration)
    say(f"fine-tuning {args.model} on {len(train)} images of {args.train} for {args.epochs} epoch(s)" +
        (" in software" if hardware is None else f": device {cfg.get('device.model')}, "
         f"{cfg.get('mapping.negative')} mapping, weight noise {args.weight_noise}"))
    start = time.monotonic()
    history = fine_tune(net, hardware, train, epochs=args.epochs, batch_size=args.batch_size, lr=args.lr,
                        optimizer=args.optimizer, momentum=args.momentum, weight_decay=args.weight_decay,
                        clip_sigma=args.clip_sigma, calibration=calibration,
                        progress=None if args.quiet else say, seed=args.seed)
    trained = net if hardware is None else _nn.to_software(net)
    _onnx.export(trained, args.out, metadata={
        "xbarsim_hwa": f"fine-tuned by xbarsim.hwa from {os.path.basename(args.model)}: {args.epochs} epoch(s) on "
                       f"{len(train)} images, device {cfg.get('device.model')}, weight noise {args.weight_noise}"})
    loss, acc = history[-1]
    say(f"wrote {args.out}: last epoch loss {loss:.4f}, train acc {100 * acc:.1f} %, "
        f"{_clock(time.monotonic() - start)}")
    return 0


def main(argv=None):
    args = _parser().parse_args(argv)  # argparse: exit 2 with its usage message

    def say(text):
        print(f"xbarsim.hwa: {text}", file=sys.stderr, flush=True)
    try:
        return _run(args, say)
    except _Usage as e:
        print(f"xbarsim.hwa: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"xbarsim.hwa: interrupted: {args.out} not written", file=sys.stderr)
        return 130


if __name__ == "__main__":
    signal.signal(signal.SIGINT, signal.default_int_handler)
    sys.exit(main())
