"""xbarsim from Python: the exact crossbar solver on NumPy arrays and the commands' results as dicts.

    import numpy as np, xbarsim
    cfg = xbarsim.Config(overrides={"crossbar.r_wire": 2.5})
    I = xbarsim.solve(G, V, cfg)            # column currents (A), one row per input vector
    r = xbarsim.overhead(preset="resnet20")  # the CLI's JSON as a dict

Errors in the input raise ValueError with the CLI's message; a solver that does not converge
raises xbarsim.SolverError. `solve` releases the GIL, so Python threads solve in parallel.
"""
import json
import os
import subprocess
import tempfile

from ._core import (Config, Crossbar, SolverError, __version__, calibration_row_picks,  # noqa: F401
                    calibration_rows_per_image, netlist, solve)
from . import _core

__all__ = ["Config", "Crossbar", "SolverError", "solve", "netlist", "eval", "simulate", "explore", "overhead", "run",
           "__version__"]


def _binary():
    """The xbarsim executable: $XBARSIM_BINARY, the one installed beside this package
    (PREFIX/bin for PREFIX/lib/python3.X/dist-packages/xbarsim), the build tree's, or the
    configured install location."""
    beside = os.path.join(os.path.dirname(os.path.abspath(__file__)), *[os.pardir] * 4, "bin", "xbarsim")
    in_build_tree = os.path.basename(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))) == "python"
    candidates = [os.environ.get("XBARSIM_BINARY")]
    candidates += [_core._binary, beside] if in_build_tree else [beside, _core._binary]
    for path in candidates + [_core._installed_binary]:
        if path and os.access(path, os.X_OK):
            return path
    raise FileNotFoundError("the xbarsim executable was not found (set XBARSIM_BINARY)")


def _config_args(config, overrides, tmp):
    args = []
    if config is not None:
        if isinstance(config, Config):
            path = os.path.join(tmp, "config.yaml")
            with open(path, "w") as f:
                f.write(config.dump())
            args += ["--config", path]
        else:  # a path to a YAML file
            args += ["--config", os.fspath(config)]
    for key, value in (overrides or {}).items():
        args += ["--set", _core._assignment(key, value)]
    return args


def run(command, *args, config=None, overrides=None, progress=None):
    """Runs `xbarsim COMMAND ARGS... --json F` and returns F's JSON as a dict.

    `progress`, if given, is called with each line the command prints on stderr (its progress
    and warnings) as it comes. An input error raises ValueError with the command's message;
    a solver failure raises SolverError.
    """
    with tempfile.TemporaryDirectory(prefix="xbarsim_") as tmp:
        out = os.path.join(tmp, "result.json")
        argv = [_binary(), command, *map(str, args), *_config_args(config, overrides, tmp), "--json", out]
        proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        lines = []
        for line in proc.stderr:
            lines.append(line)
            if progress is not None:
                progress(line.rstrip("\n"))
        code = proc.wait()
        if code != 0:
            message = "".join(lines).strip()
            for prefix in (f"xbarsim {command}: error: ", "xbarsim: error: "):
                message = "\n".join(l[len(prefix):] if l.startswith(prefix) else l for l in message.splitlines())
            if code == 2:
                raise ValueError(message)
            if "solver" in message.lower() and "converge" in message.lower():
                raise SolverError(message)
            raise RuntimeError(f"xbarsim {command} failed (exit {code}): {message}")
        with open(out) as f:
            return json.load(f)


def _model_args(model, preset):
    if model is not None:
        return ["--model", os.fspath(model)]
    if preset is not None:
        return ["--preset", preset]
    raise ValueError("give model= (an ONNX file or a shared model's name) or preset=")


def eval(model, dataset=None, images=None, config=None, overrides=None, progress=None, **options):
    """`xbarsim eval`: accuracy on crossbars vs software and per-layer errors, as a dict."""
    args = _model_args(model, None)
    if dataset is not None:
        args += ["--dataset", os.fspath(dataset)]
    if images is not None:
        args += ["--images", str(images)]
    for key, value in options.items():
        args += ["--" + key.replace("_", "-"), str(value)]
    return run("eval", *args, config=config, overrides=overrides, progress=progress)


def simulate(model=None, preset=None, dataset=None, images=None, timing_only=False, config=None, overrides=None,
             progress=None):
    """`xbarsim simulate`: the SystemC/TLM-2.0 platform's timing, energy, area (and accuracy), as a dict."""
    args = _model_args(model, preset)
    if dataset is not None:
        args += ["--dataset", os.fspath(dataset)]
    if images is not None:
        args += ["--images", str(images)]
    if timing_only:
        args.append("--timing-only")
    return run("simulate", *args, config=config, overrides=overrides, progress=progress)


def overhead(model=None, preset=None, config=None, overrides=None):
    """`xbarsim overhead`: dense vs sparse mapping cost per layer, as a dict."""
    return run("overhead", *_model_args(model, preset), config=config, overrides=overrides)


def explore(space, out, model=None, dataset=None, images=None, overrides=None, progress=None):
    """`xbarsim explore`: every point and the Pareto front, as a dict. `space` is the YAML file of
    the space; `out` the resumable JSON-lines journal."""
    args = ["--config", os.fspath(space), "--out", os.fspath(out)]
    if model is not None:
        args += ["--model", os.fspath(model)]
    if dataset is not None:
        args += ["--dataset", os.fspath(dataset)]
    if images is not None:
        args += ["--images", str(images)]
    return run("explore", *args, overrides=overrides, progress=progress)
