"""The ONNX reader the tests used before it became package API (issue 41): xbarsim.onnx."""
from xbarsim.onnx import OnnxModule  # noqa: F401
