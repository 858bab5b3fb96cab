"""The commands (eval, simulate, overhead, explore; any with run) from Python: each runs the
xbarsim executable in a child process and returns its JSON as a dict, so results are the CLI's by
construction and a SystemC simulation can run any number of times from one session.
`xbarsim.eval(...)` and the others are these functions, re-exported."""
import json
import os
import subprocess
import tempfile

from . import Config, SolverError, _core

__all__ = ["eval", "simulate", "overhead", "explore", "run"]


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


# The options of each command beyond --config, --set and --json, as keyword arguments (the
# parameters a wrapper names are not repeated): a keyword not among them is a TypeError naming it.
_OPTIONS = {
    "eval": ("offset", "journal", "csv", "report"),
    "simulate": ("timing", "vcd", "vcd_images", "report", "csv"),
    "overhead": ("input_size", "csv"),
    "explore": ("report", "csv"),
}


def _option_args(command, options):
    """`options` (keyword arguments) as the command's flags: `vcd_images=2` is `--vcd-images 2`."""
    allowed = _OPTIONS.get(command, ())
    args = []
    for key, value in options.items():
        if key not in allowed:
            raise TypeError(f"{command}() got an unexpected keyword argument '{key}' (its options: " +
                            ", ".join(allowed) + ", and json)")
        args += ["--" + key.replace("_", "-"), os.fspath(value) if hasattr(value, "__fspath__") else str(value)]
    return args


def run(command, *args, config=None, overrides=None, progress=None, json_path=None):
    """Runs `xbarsim COMMAND ARGS... --json F` and returns F's JSON.

    The result is a dict, or for a sweep (a list value in `config` or `overrides`) a list of
    dicts, one per point, each with the point's values under "sweep". `json_path`, if given,
    is where the JSON is written (and kept); else a temporary file. `progress`, if given, is
    called with each line the command prints on stderr (its progress and warnings) as it comes.
    An input error raises ValueError with the command's message; a solver failure raises
    SolverError.
    """
    if "--json" in map(str, args):
        raise ValueError("give the JSON file as json= (the wrappers) or json_path= (run), not as --json")
    with tempfile.TemporaryDirectory(prefix="xbarsim_") as tmp:
        out = os.fspath(json_path) if json_path is not None else os.path.join(tmp, "result.json")
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


def eval(model, dataset=None, images=None, config=None, overrides=None, progress=None, json=None, **options):
    """`xbarsim eval`: a whole ONNX network on crossbars against software on the same images.

    `model`: an ONNX file or a shared model's name; `dataset`: cifar10, mnist or a .npz file
    (default: the model's); `images`: how many test images (default all). `config` (a Config or
    a YAML path) and `overrides` ({"dotted.key": value}) as for Config; `progress(line)` gets
    each line the command prints on stderr; `json`: a file to keep the JSON in. Further options
    as keywords: offset, journal, csv, report (`--offset` ...; another keyword is a TypeError).

    Returns the CLI's JSON: a dict (accuracies, the drop and its interval, per-layer errors
    under "layers", cost, "warnings"), or for a sweep a list of such dicts, one per point.
    """
    args = _model_args(model, None)
    if dataset is not None:
        args += ["--dataset", os.fspath(dataset)]
    if images is not None:
        args += ["--images", str(images)]
    args += _option_args("eval", options)
    return run("eval", *args, config=config, overrides=overrides, progress=progress, json_path=json)


def simulate(model=None, preset=None, dataset=None, images=None, timing_only=False, config=None, overrides=None,
             progress=None, json=None, **options):
    """`xbarsim simulate`: the SystemC/TLM-2.0 accelerator's timing, energy, area (and accuracy).

    `model` (an ONNX file or a shared model's name) or `preset` (a built-in topology);
    `dataset` and `images` as for eval (`images`: how many images to simulate);
    `timing_only`: skip the values (no dataset needed). `config`, `overrides`, `progress` and
    `json` as for eval. Further options as keywords: timing ("ideal" or "detailed"), vcd,
    vcd_images, report, csv.

    Returns the CLI's JSON: a dict (latency, throughput, energy and area with their breakdowns,
    per-layer figures), or for a sweep a list of such dicts, one per point.
    """
    args = _model_args(model, preset)
    if dataset is not None:
        args += ["--dataset", os.fspath(dataset)]
    if images is not None:
        args += ["--images", str(images)]
    if timing_only:
        args.append("--timing-only")
    args += _option_args("simulate", options)
    return run("simulate", *args, config=config, overrides=overrides, progress=progress, json_path=json)


def overhead(model=None, preset=None, config=None, overrides=None, json=None, **options):
    """`xbarsim overhead`: dense vs sparse (Toeplitz) mapping cost per layer.

    `model` or `preset` as for simulate; `config`, `overrides` and `json` as for eval. Further
    options as keywords: input_size ("H,W"), csv.

    Returns the CLI's JSON: a dict (per layer: crossbars, converters, utilization, power and
    area of each mapping), or for a sweep a list of such dicts, one per point.
    """
    args = _model_args(model, preset) + _option_args("overhead", options)
    return run("overhead", *args, config=config, overrides=overrides, json_path=json)


def explore(space, out, model=None, dataset=None, images=None, overrides=None, progress=None, json=None, **options):
    """`xbarsim explore`: accuracy and cost of every point of a design space, and the Pareto front.

    `space`: the YAML file of the space; `out`: the resumable JSON-lines journal; `model`,
    `dataset`, `images`, `overrides`, `progress` and `json` as for eval. Further options as
    keywords: report, csv.

    Returns the CLI's JSON as a dict (every point, the front).
    """
    args = ["--config", os.fspath(space), "--out", os.fspath(out)]
    if model is not None:
        args += ["--model", os.fspath(model)]
    if dataset is not None:
        args += ["--dataset", os.fspath(dataset)]
    if images is not None:
        args += ["--images", str(images)]
    args += _option_args("explore", options)
    return run("explore", *args, overrides=overrides, progress=progress, json_path=json)
