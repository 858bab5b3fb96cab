"""xbarsim from Python: the exact crossbar solver on NumPy arrays and the commands' results as dicts.

    import numpy as np, xbarsim
    cfg = xbarsim.Config(overrides={"crossbar.r_wire": 2.5})
    I = xbarsim.solve(G, V, cfg)            # column currents (A), one row per input vector
    r = xbarsim.overhead(preset="resnet20")  # the CLI's JSON as a dict
    pcm = xbarsim.Device({"device.model": "pcm-joshi2020"})
    G1 = pcm.at_time(G, pcm.program(G), t=86400)  # programmed, then a day later (S)

The package, laid out as aihwkit's:
- `xbarsim` (this module): the core bindings (Config, solve, Crossbar, Device, netlist, ...);
- `xbarsim.nn`: analog Conv2d/Linear for hardware-aware training (autograd, straight-through);
- `xbarsim.inference`: the exact evaluation of a torch model on crossbars, devices and time;
- `xbarsim.onnx`: ONNX models as trainable torch modules, and export back to ONNX;
- `xbarsim.data`: CIFAR-10's binary batches with augmentation;
- `xbarsim.hwa`: `python3 -m xbarsim.hwa`, hardware-aware fine-tuning of an ONNX model;
- `xbarsim.commands`: the CLI wrappers (eval, simulate, overhead, explore, run), also here.

Errors in the input raise ValueError with the CLI's message; a solver that does not converge
raises xbarsim.SolverError. `solve` releases the GIL, so Python threads solve in parallel.
The command wrappers are called qualified (`xbarsim.eval(...)`): `from xbarsim import *` leaves
out `eval`, which would shadow the builtin.
"""
import os
import sys

try:
    from ._core import (Config, Crossbar, Device, SolverError, __version__, calibration_row_picks,  # noqa: F401
                        calibration_rows_per_image, layer_output_range, netlist, output_errors, solve)
    from . import _core
except ImportError as e:
    # The extension is built for one interpreter (its ABI tag is in the file name): another one
    # (a pyenv or venv python3 first on PATH) does not find it. Say which one it needs.
    try:
        from ._built_for import PYTHON as _PYTHON, VERSION as _VERSION
    except ImportError:
        raise e from None
    if (f"{sys.version_info[0]}.{sys.version_info[1]}" == _VERSION and
            os.path.realpath(sys.executable) == os.path.realpath(_PYTHON)):
        raise  # the right interpreter: the extension itself fails to load
    raise ImportError(
        f"xbarsim's extension (xbarsim._core) is built for {_PYTHON} (Python {_VERSION}), but this is "
        f"{sys.executable} (Python {sys.version_info[0]}.{sys.version_info[1]}): run {_PYTHON} instead "
        f"(or rebuild with -DPython3_EXECUTABLE={sys.executable}); the import said: {e}") from e

__all__ = ["Config", "Crossbar", "Device", "SolverError", "solve", "netlist", "output_errors", "layer_output_range",
           "simulate", "explore", "overhead", "run", "__version__"]


from .commands import eval, explore, overhead, run, simulate  # noqa: E402,F401  (the CLI wrappers)
