"""Inference on the exact circuit, over time: a torch model's Conv2d and Linear layers programmed
onto crossbars as `xbarsim eval` programs them (wires, mitigation, converters, the device model)
and read at any time after programming.

    import xbarsim.inference as inf
    analog = inf.convert(model, xbarsim.Config(overrides={"device.model": "rram-wan2022"}), calibration=images)
    for t in [1, 86400, 3.15e7]:
        inf.set_time(analog, t, compensation="global")
        result = inf.evaluate(analog, loader, reference=model)

`Device` is the device model on NumPy arrays of conductances. The functions are those of
`xbarsim.torch` (where they are documented); this module is their place in the package's layout,
beside `xbarsim.nn` (training)."""
from . import Device  # noqa: F401
from .torch import AnalogConv2d as CrossbarConv2d  # noqa: F401
from .torch import AnalogLinear as CrossbarLinear  # noqa: F401
from .torch import convert, evaluate, set_image, set_time  # noqa: F401

__all__ = ["Device", "convert", "evaluate", "set_time", "set_image", "CrossbarConv2d", "CrossbarLinear"]
