"""Hardware-aware fine-tuning of an ONNX model, for `xbarsim eval` to check on the exact circuit.

    python3 -m xbarsim.hwa --model M.onnx --train DIR [--recipe neurram|pcm-joshi2020] [--epochs N]
        [--config F] [--set key=value]... --out OUT.onnx [--resume]

trains M with the configuration's device model and converters in the forward (xbarsim.nn's
fast training path) on DIR's CIFAR-10 training batches (a recipe's settings, the user's over
them), keeps the epoch that scores best on held-out training images, and writes OUT: the same
graph with the trained weights and M's preprocessing metadata; a checkpoint after every epoch
lets --resume go on. From Python: fine_tune(model, hardware, data).
"""
import argparse
import copy
import hashlib
import json
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

__all__ = ["fine_tune", "clip_weights", "RECIPES", "main"]

# Training recipes: settings with their sources. A user's own options override them one by one.
# `what` says where each setting comes from and what we changed (docs/python.md, recipes).
_DEFAULTS = {"epochs": 1, "optimizer": "adam", "lr": 1e-4, "warmup": 0.0, "schedule": "cosine", "weight_noise": 0.0,
             "noise_scale": 1.0, "clip_sigma": 3.0, "time": None, "distill": 0.0, "temperature": 4.0}


def _recipe(what, **changes):
    """A recipe: the default settings with `changes`, and `what` says where they come from."""
    return {"what": what, **_DEFAULTS, **changes}


RECIPES = {
    "default": _recipe("issue 41's fine-tune: Adam at 1e-4, cosine decay, +-3 sigma clipping, the device's own noise"),
    "neurram": _recipe(
        "Wan et al. 2022 (Nature 608, NeuRRAM): Gaussian weight noise of a fraction of each layer's "
        "largest |weight| in the forward, the chip's quantizers in the loop. They trained from scratch "
        "with 0.2; fine-tuning a clean model with 0.2 collapses in one epoch (docs/results.md), so the "
        "noise is 0.05 here, ramped in over the warm-up epoch, on top of the device model's own "
        "spread; 16 epochs, Adam 3e-4 with a one-epoch warm-up and cosine decay, +-3 sigma clipping, "
        "and distillation from the software model (0.7 at T 4; Hinton et al. 2015, as quantization-aware "
        "training uses it: the fine-tune starts from a full-precision model that can teach)",
        epochs=16, lr=3e-4, warmup=1.0, weight_noise=0.05, distill=0.7),
    "pcm-joshi2020": _recipe(
        "Joshi et al. 2020 (Nat. Commun. 11, 2473): noise injection during training (3.8 % of each "
        "layer's largest |weight| for ResNet-32 on CIFAR-10), weight clipping, global drift "
        "compensation at inference. Here the device model's own programming, drift and 1/f deviations "
        "are injected instead, at times drawn log-uniformly over 1 s .. 1 year, plus the 3.8 %; "
        "8 epochs, Adam 3e-4, one warm-up epoch, cosine decay, +-3 sigma clipping; distillation from "
        "the software model (0.7 at T 4), which they did not use (they trained from scratch)",
        epochs=8, lr=3e-4, warmup=1.0, weight_noise=0.038, time="1,31536000", distill=0.7),
}


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


def _lr_factor(k, total, warmup_steps, schedule):
    """The learning rate's factor at step k of `total`: linear warm-up over `warmup_steps`, then
    a cosine to 0 (`cosine`) or steps of x0.1 at half and three quarters of the rest (`step`)."""
    if k < warmup_steps:
        return (k + 1) / warmup_steps
    rest = max(total - warmup_steps, 1)
    u = (k - warmup_steps) / rest
    if schedule == "cosine":
        return 0.5 * (1 + math.cos(math.pi * u))
    if schedule == "step":
        return 1.0 if u < 0.5 else 0.1 if u < 0.75 else 0.01
    raise ValueError(f"schedule must be cosine or step, got {schedule}")


def accuracy(model, data, hardware=None, batch_size=256):
    """The fraction of `data` (an xbarsim.data.Cifar10 set, not augmented) that `model` classifies
    right, in its training forward (with `hardware`: a fresh draw of the device per batch)."""
    was = model.training
    model.eval()
    correct = 0
    with torch.no_grad():
        for x, y in data.batches(batch_size, shuffle=False):
            if hardware is not None:
                hardware.new_batch()
                _nn.draw(model)
            correct += int((model(x).argmax(1) == y).sum())
    model.train(was)
    return correct / len(data)


def fine_tune(model, hardware, train, epochs=1, batch_size=128, lr=1e-4, optimizer="adam", momentum=0.9,
              weight_decay=0.0, clip_sigma=3.0, calibration=None, progress=None, seed=0, warmup=0.0,
              schedule="cosine", validation=None, checkpoint=None, resume=None, signature=None, teacher=None,
              distill=0.0, temperature=4.0):
    """Trains `model` (a module with xbarsim.nn analog layers, or a plain one: trained in
    software) on `train` (an xbarsim.data.Cifar10 set) for `epochs` epochs: Adam (or SGD with
    momentum), the learning rate `lr` warmed up linearly over the first `warmup` epochs and then
    decayed by `schedule` (cosine to 0, or step: x0.1 at half and three quarters of the rest),
    cross-entropy loss, the weights clipped to +-clip_sigma standard deviations of their layer
    before training and after every step (clip_weights; 0: none). Every batch draws the
    hardware's programming error, faults, drift (hardware.new_batch()); the hardware's weight
    noise ramps in linearly over the warm-up; every epoch starts by calibrating the DAC and ADC
    ranges on `calibration` (a batch of inputs; default the first 200 training images, not
    augmented). `validation` (a Cifar10 set of held-out TRAINING images, never the test set):
    scored after every epoch in the training forward; the model of the best epoch is the one
    returned (model selection). `checkpoint`: a path written whole after every epoch (os.replace
    of a finished file); `resume`: a checkpoint's path to go on from (its `signature` must equal
    this run's). `teacher` (a module, e.g. the software model; with `distill` in (0, 1]):
    knowledge distillation (Hinton et al. 2015), the loss (1 - distill) x cross-entropy + distill x
    temperature^2 x KL(teacher || model) of their outputs softened by `temperature`.
    `progress(text)` gets a line about every 10 % of an epoch. Returns a list of per-epoch (loss,
    training accuracy, validation accuracy or None)."""
    if not (0 <= distill <= 1):
        raise ValueError(f"distill must be in [0, 1], got {distill}")
    if not (temperature > 0 and math.isfinite(temperature)):
        raise ValueError(f"temperature must be a number > 0, got {temperature}")
    if distill > 0 and teacher is None:
        raise ValueError("distill > 0 needs a teacher")
    if teacher is not None:
        teacher.eval()
    torch.manual_seed(seed)
    analog = _nn.analog_layers(model)
    if hardware is None and analog:
        hardware = analog[0].hw
    if not (warmup >= 0 and warmup <= epochs):
        raise ValueError(f"warmup must be in [0, epochs = {epochs}] epochs, got {warmup}")
    params = [p for p in model.parameters() if p.requires_grad]
    if optimizer == "adam":
        opt = torch.optim.Adam(params, lr=lr, weight_decay=weight_decay)
    elif optimizer == "sgd":
        opt = torch.optim.SGD(params, lr=lr, momentum=momentum, weight_decay=weight_decay)
    else:
        raise ValueError(f"optimizer must be adam or sgd, got {optimizer}")
    _lr_factor(0, 1, 0, schedule)  # refuses an unknown schedule before any work
    steps_per_epoch = math.ceil(len(train) / batch_size)
    total = epochs * steps_per_epoch
    warmup_steps = int(round(warmup * steps_per_epoch))
    sched = torch.optim.lr_scheduler.LambdaLR(opt, lambda k: _lr_factor(k, total, warmup_steps, schedule))
    noise = hardware.weight_noise if hardware is not None else 0.0
    if calibration is None:
        calibration = train.preprocess(train.images[:200])
    history, best, best_state, first = [], -1.0, None, 0
    if resume is not None:
        state = torch.load(resume)
        if state.get("signature") != signature:
            raise ValueError(f"{resume}: a checkpoint of another model, data or configuration "
                             f"(it was written for: {state.get('signature')})")
        model.load_state_dict(state["model"])
        opt.load_state_dict(state["optimizer"])
        sched.load_state_dict(state["scheduler"])
        torch.set_rng_state(state["torch_rng"])
        history, best, best_state, first = state["history"], state["best"], state["best_state"], state["epoch"]
        if hardware is not None:
            hardware.step = state["hardware_step"]
        for m, reads in zip(analog, state["reads"]):  # each layer's read-noise stream goes on
            m._reads = reads
    else:
        clip_weights(model, clip_sigma)
    start = time.monotonic()
    step = first * steps_per_epoch
    done_here = 0
    calibrated = None  # the step the model was last calibrated at (validation's serves the next epoch)
    try:
        for epoch in range(first, epochs):
            if analog and calibrated != step:
                _nn.calibrate(model, calibration)
            model.train()
            seen, correct, loss_sum = 0, 0, 0.0
            next_report = 0.1
            for x, y in train.batches(batch_size, epoch=epoch):
                if hardware is not None:
                    hardware.weight_noise = noise * min(1.0, (step + 1) / warmup_steps) if warmup_steps else noise
                    hardware.new_batch()
                    _nn.draw(model)
                out = model(x)
                loss = F.cross_entropy(out, y)
                if distill > 0:
                    with torch.no_grad():
                        soft = F.softmax(teacher(x) / temperature, dim=1)
                    kd = F.kl_div(F.log_softmax(out / temperature, dim=1), soft, reduction="batchmean")
                    loss = (1 - distill) * loss + distill * temperature ** 2 * kd
                opt.zero_grad(set_to_none=True)
                loss.backward()
                opt.step()
                sched.step()
                clip_weights(model, clip_sigma)
                step += 1
                seen += len(y)
                done_here += len(y)
                correct += int((out.detach().argmax(1) == y).sum())
                loss_sum += float(loss) * len(y)
                if progress is not None and (seen >= next_report * len(train) or seen == len(train)):
                    next_report += 0.1
                    elapsed = time.monotonic() - start
                    rate = done_here / elapsed if elapsed > 0 else 0.0
                    left = ((total - step) * batch_size) / rate if rate > 0 else 0.0
                    progress(f"epoch {epoch + 1}/{epochs}  {seen}/{len(train)} images  loss {loss_sum / seen:.4f}  "
                             f"train acc {100 * correct / seen:.1f} %  {rate:.0f} images/s  "
                             f"elapsed {_clock(elapsed)}  left {_clock(left)}")
            val = None
            if validation is not None:
                if analog:
                    _nn.calibrate(model, calibration)
                    calibrated = step
                val = accuracy(model, validation, hardware)
                if val > best:
                    best = val
                    best_state = {k: v.detach().clone() for k, v in model.state_dict().items()}
                if progress is not None:
                    progress(f"epoch {epoch + 1}/{epochs}  validation {100 * val:.2f} % on {len(validation)} held-out "
                             f"training images (best {100 * best:.2f} %)")
            history.append((loss_sum / seen, correct / seen, val))
            if checkpoint is not None:
                tmp = f"{checkpoint}.tmp"
                torch.save({"signature": signature, "epoch": epoch + 1, "model": model.state_dict(),
                            "optimizer": opt.state_dict(), "scheduler": sched.state_dict(),
                            "torch_rng": torch.get_rng_state(), "history": history, "best": best,
                            "best_state": best_state,
                            "hardware_step": hardware.step if hardware is not None else 0,
                            "reads": [m._reads for m in analog]}, tmp)
                os.replace(tmp, checkpoint)
    finally:
        if hardware is not None:
            hardware.weight_noise = noise
        if checkpoint is not None and os.path.exists(f"{checkpoint}.tmp"):
            os.remove(f"{checkpoint}.tmp")
    if best_state is not None:
        model.load_state_dict(best_state)
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
    p.add_argument("--recipe", choices=sorted(RECIPES), default="default",
                   help="a preset of the training settings below, with its source: " +
                        "; ".join(f"{k}: {v['what']}" for k, v in sorted(RECIPES.items())).replace("%", "%%") +
                        ". Every option given on the command line overrides the recipe's")
    p.add_argument("--epochs", type=int, metavar="N", help="passes over the training images (>= 1; the recipe's)")
    p.add_argument("--out", required=True, metavar="OUT.onnx",
                   help="where the fine-tuned model is written (whole, or not at all when interrupted)")
    p.add_argument("--config", metavar="F", help="xbarsim configuration YAML (as for xbarsim eval)")
    p.add_argument("--set", action="append", default=[], metavar="key=value",
                   help="override one configuration key (repeatable), e.g. --set device.model=rram-wan2022")
    p.add_argument("--weight-noise", type=float, metavar="F",
                   help="NeuRRAM's training noise: Gaussian weight noise of F x each layer's largest |weight|, "
                        "drawn per batch, on top of the device model, ramped in over the warm-up (the recipe's)")
    p.add_argument("--noise-scale", type=float, metavar="F",
                   help="train with the device's deviations (programming error, drift, read noise) times F "
                        "(the recipe's; 1 = as the device)")
    p.add_argument("--time", metavar="T|T0,T1",
                   help="seconds after programming each batch reads at: T, or T0,T1 drawn log-uniformly per batch "
                        "(the recipe's, else device.time_s)")
    p.add_argument("--distill", type=float, metavar="F",
                   help="knowledge distillation from the input model in software: the loss is (1 - F) x "
                        "cross-entropy + F x T^2 x KL divergence from its softened outputs (0: none; the recipe's)")
    p.add_argument("--temperature", type=float, metavar="T",
                   help="the distillation's softening temperature (> 0; the recipe's)")
    p.add_argument("--batch-size", type=int, default=128, metavar="B", help="images per batch (default 128)")
    p.add_argument("--optimizer", choices=("adam", "sgd"), help="adam or sgd (with momentum; the recipe's)")
    p.add_argument("--lr", type=float,
                   help="peak learning rate, after the warm-up (the recipe's; the shared models have their batch "
                        "norms folded, and SGD above 1e-3 diverges)")
    p.add_argument("--warmup", type=float, metavar="E",
                   help="epochs of linear learning-rate (and weight-noise) warm-up (the recipe's)")
    p.add_argument("--schedule", choices=("cosine", "step"),
                   help="after the warm-up: cosine to 0, or step (x0.1 at half and three quarters; the recipe's)")
    p.add_argument("--momentum", type=float, default=0.9, help="SGD momentum (default 0.9)")
    p.add_argument("--clip-sigma", type=float, metavar="C",
                   help="clip every layer's weights to +-C standard deviations of the layer before and after every "
                        "step (the recipe's; 0: none): outliers cost every other weight its range and noise margin")
    p.add_argument("--weight-decay", type=float, default=0.0, help="SGD weight decay (default 0)")
    p.add_argument("--images", type=int, metavar="N", help="use only the first N training images")
    p.add_argument("--validation-images", type=int, metavar="V",
                   help="hold out the last V training images (never the test set): scored after every epoch, and "
                        "the best epoch's model is written (default 2000, a tenth of a set under 20 000; 0: none, "
                        "the last epoch's)")
    p.add_argument("--checkpoint", metavar="F",
                   help="written whole after every epoch (default OUT.ckpt); removed when the model is written")
    p.add_argument("--resume", action="store_true",
                   help="go on from the checkpoint of an interrupted run with the same model, data, configuration "
                        "and settings")
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


def _settings(args):
    """The recipe's settings with the options given on the command line over them."""
    recipe = dict(RECIPES[args.recipe])
    for key in ("epochs", "optimizer", "lr", "warmup", "schedule", "weight_noise", "noise_scale", "clip_sigma", "time",
                "distill", "temperature"):
        value = getattr(args, key)
        if value is not None:
            recipe[key] = value
    return recipe


def _signature(args, cfg, s, train_files):
    """What a checkpoint must have been written for to be resumed: the model's bytes, the
    training files, the configuration and every training setting."""
    h = hashlib.sha256()
    with open(args.model, "rb") as f:
        h.update(f.read())
    for path in train_files:
        h.update(os.path.basename(path).encode())
        h.update(str(os.path.getsize(path)).encode())
    keys = {k: v for k, v in s.items() if k != "what"}
    keys.update(config=cfg.to_dict(), batch_size=args.batch_size, momentum=args.momentum,
                weight_decay=args.weight_decay, images=args.images, validation_images=args.validation_images,
                seed=args.seed, software=args.software)
    h.update(json.dumps(keys, sort_keys=True, default=str).encode())
    return h.hexdigest()


def _run(args, say):
    s = _settings(args)
    for name, value, low in (("--epochs", s["epochs"], 1), ("--batch-size", args.batch_size, 1),
                             ("--threads", args.threads, 0), ("--validation-images", args.validation_images or 0, 0)):
        if value < low:
            raise _Usage(f"{name} must be >= {low}, got {value}")
    if args.images is not None and args.images < 1:
        raise _Usage(f"--images must be >= 1, got {args.images}")
    if not (s["lr"] > 0 and math.isfinite(s["lr"])):
        raise _Usage(f"--lr must be a number > 0, got {s['lr']}")
    for name, key in (("--clip-sigma", "clip_sigma"), ("--weight-noise", "weight_noise"),
                      ("--noise-scale", "noise_scale"), ("--warmup", "warmup")):
        if not (s[key] >= 0 and math.isfinite(s[key])):
            raise _Usage(f"{name} must be a number >= 0, got {s[key]}")
    if not (0 <= s["distill"] <= 1):
        raise _Usage(f"--distill must be in [0, 1], got {s['distill']}")
    if not (s["temperature"] > 0 and math.isfinite(s["temperature"])):
        raise _Usage(f"--temperature must be a number > 0, got {s['temperature']}")
    if s["warmup"] > s["epochs"]:
        raise _Usage(f"--warmup ({s['warmup']} epochs) is longer than the training ({s['epochs']} epochs)")
    out_dir = os.path.dirname(os.path.abspath(args.out))
    if not os.path.isdir(out_dir):
        raise _Usage(f"--out {args.out}: the directory {out_dir} does not exist")
    if os.path.abspath(args.out) == os.path.abspath(args.model):
        raise _Usage("--out names the input model: write the fine-tuned model to another file")
    checkpoint = args.checkpoint or f"{args.out}.ckpt"
    if os.path.abspath(checkpoint) in (os.path.abspath(args.model), os.path.abspath(args.out)):
        raise _Usage("--checkpoint names the input model or the output: give it a file of its own")
    if args.resume and not os.path.isfile(checkpoint):
        raise _Usage(f"--resume: no checkpoint {checkpoint} to go on from")
    cfg = _config(args)
    try:
        model = _onnx.load(args.model)
        preprocessing = model.preprocessing
        train = _data.Cifar10(args.train, train=True, preprocessing=preprocessing, limit=args.images, seed=args.seed)
        validation = None
        if args.validation_images is None:
            args.validation_images = min(2000, len(train) // 10)
        if args.validation_images:
            if args.validation_images >= len(train):
                raise ValueError(f"--validation-images {args.validation_images} leaves no training image of "
                                 f"{len(train)}")
            validation = copy.copy(train)
            validation.images, validation.labels = train.images[-args.validation_images:], train.labels[-args.validation_images:]
            validation.augment = False
            train.images, train.labels = train.images[:-args.validation_images], train.labels[:-args.validation_images]
        calib_file = os.path.join(args.train, "calib_batch.bin")
        calibration = None
        if os.path.isfile(calib_file):
            calib = _data.Cifar10(files=[calib_file], train=False, preprocessing=preprocessing, limit=200)
            calibration = calib.preprocess(calib.images)
        hardware = None if args.software else _nn.Hardware(cfg, weight_noise=s["weight_noise"],
                                                             time_s=_times(s["time"]), seed=args.seed,
                                                             noise_scale=s["noise_scale"])
    except ValueError as e:
        raise _Usage(str(e)) from None
    signature = _signature(args, cfg, s, train.files)
    if args.resume:
        try:
            previous = torch.load(checkpoint).get("signature")
        except Exception as e:  # a file that is not a checkpoint
            raise _Usage(f"--resume: {checkpoint} is not a checkpoint of xbarsim.hwa ({type(e).__name__})") from None
        if previous != signature:
            raise _Usage(f"--resume: {checkpoint} was written for another model, data, configuration or settings")
    if calibration is None:
        calibration = train.preprocess(train.images[:200])
    torch.set_num_threads(args.threads or os.cpu_count() or 1)
    net = model if hardware is None else _nn.convert(model, hardware, calibration=calibration)
    # The teacher is the input model in software; trained in software, it is the model itself.
    distill = s["distill"] if hardware is not None else 0.0
    say(f"training {args.model} on {len(train)} images of {args.train}"
        f"{f' ({len(validation)} held out for validation)' if validation is not None else ''}: recipe {args.recipe}, "
        f"{s['epochs']} epoch(s), {s['optimizer']} lr {s['lr']:g}, warm-up {s['warmup']:g}, {s['schedule']}" +
        (" in software" if hardware is None else f", device {cfg.get('device.model')}, "
         f"{hardware.mapper.negative} mapping, weight noise {s['weight_noise']:g}") +
        (f", distillation {distill:g} at T {s['temperature']:g}" if distill > 0 else "") +
        (f"; going on from {checkpoint}" if args.resume else ""))
    start = time.monotonic()
    history = fine_tune(net, hardware, train, epochs=s["epochs"], batch_size=args.batch_size, lr=s["lr"],
                        optimizer=s["optimizer"], momentum=args.momentum, weight_decay=args.weight_decay,
                        clip_sigma=s["clip_sigma"], calibration=calibration,
                        progress=None if args.quiet else say, seed=args.seed, warmup=s["warmup"],
                        schedule=s["schedule"], validation=validation, checkpoint=checkpoint,
                        resume=checkpoint if args.resume else None, signature=signature,
                        teacher=model if distill > 0 else None, distill=distill, temperature=s["temperature"])
    trained = net if hardware is None else _nn.to_software(net)
    best = max(range(len(history)), key=lambda k: history[k][2]) if validation is not None else len(history) - 1
    tmp = f"{args.out}.tmp"
    _onnx.export(trained, tmp, metadata={
        "xbarsim_hwa": f"trained by xbarsim.hwa from {os.path.basename(args.model)}: recipe {args.recipe}, "
                       f"{s['epochs']} epoch(s) on {len(train)} images (epoch {best + 1} kept), device "
                       f"{cfg.get('device.model')}, weight noise {s['weight_noise']:g}"})
    os.replace(tmp, args.out)
    os.remove(checkpoint)
    loss, acc, val = history[best]
    say(f"wrote {args.out}: epoch {best + 1} of {len(history)}, loss {loss:.4f}, train acc {100 * acc:.1f} %" +
        (f", validation {100 * val:.2f} %" if val is not None else "") + f", {_clock(time.monotonic() - start)}")
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
        if os.path.exists(f"{args.out}.tmp"):
            os.remove(f"{args.out}.tmp")
        ckpt = args.checkpoint or f"{args.out}.ckpt"
        kept = f"; the last whole epoch is in {ckpt} (--resume goes on from it)" if os.path.isfile(ckpt) else ""
        print(f"xbarsim.hwa: interrupted: {args.out} not written{kept}", file=sys.stderr)
        return 130


if __name__ == "__main__":
    signal.signal(signal.SIGINT, signal.default_int_handler)
    sys.exit(main())
