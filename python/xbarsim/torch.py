"""xbarsim.torch, the PyTorch bridge's first name: the functions and layer classes of
xbarsim.inference (where they live and are documented), kept under this name so that code
written for it goes on working.

    import xbarsim, xbarsim.torch
    analog = xbarsim.torch.convert(model, xbarsim.Config(), calibration=images)  # = xbarsim.inference.convert
"""
from .inference import AnalogConv2d, AnalogLinear, convert, evaluate, set_image, set_time  # noqa: F401

__all__ = ["convert", "evaluate", "set_time", "set_image", "AnalogConv2d", "AnalogLinear"]
