"""ONNX models as torch modules and back: read an ONNX network (the shared models' ops) into a
trainable torch module, and write a (fine-tuned) module as an ONNX file `xbarsim eval` runs.

    import xbarsim.onnx
    model = xbarsim.onnx.load("resnet20_cifar10.onnx")   # Conv/Gemm -> Conv2d/Linear, graph order
    scale, mean, std = model.preprocessing             # from the file's metadata_props
    ...                                                 # fine-tune model
    xbarsim.onnx.export(model, "resnet20_hwa.onnx")     # the same graph with the new weights

Ops read: Conv, Gemm, Relu, Add, Slice, Pad, MaxPool, AveragePool, GlobalAveragePool, Flatten,
Reshape (to N x -1). Conv and Gemm become Conv2d and Linear modules registered in graph order
(the order eval numbers its linear layers in, so xbarsim.nn's and xbarsim.inference's layer
index l is eval's); the rest is computed node by node.
"""
import os
import tempfile

import numpy as np
import onnx as _onnx
import onnx.numpy_helper as _numpy_helper
import torch
import torch.nn.functional as F

__all__ = ["OnnxModule", "load", "export"]

_OPS = ("Conv", "Gemm", "Relu", "Add", "Slice", "Pad", "MaxPool", "AveragePool", "GlobalAveragePool", "Flatten",
        "Reshape")


def _unsupported(path, node, why):
    return ValueError(f"{path}: node '{node.name or node.output[0]}' ({node.op_type}): {why}")


class OnnxModule(torch.nn.Module):
    """An ONNX graph as a torch module (module docstring). `layers`: its Conv2d/Linear in graph
    order; `metadata`: the file's metadata_props; `preprocessing`: (scale, mean, std) from them
    (x = (pixel * scale - mean[c]) / std[c]); `source`: the ModelProto it was read from."""

    def __init__(self, path):
        super().__init__()
        path = os.fspath(path)
        try:
            model = _onnx.load(path)
        except FileNotFoundError:
            raise ValueError(f"{path}: no such file") from None
        except Exception as e:  # a file that is not an ONNX model (protobuf's DecodeError, ...)
            raise ValueError(f"{path}: not an ONNX model ({type(e).__name__}: {e})") from None
        g = model.graph
        if len(g.input) < 1 or len(g.output) != 1:
            raise ValueError(f"{path}: the graph needs one input and one output")
        self.source = model
        self.path = path
        self.metadata = {p.key: p.value for p in model.metadata_props}
        init = {t.name: torch.from_numpy(_numpy_helper.to_array(t).copy()) for t in g.initializer}
        self.input_name, self.output_name = g.input[0].name, g.output[0].name
        self.layers = torch.nn.ModuleList()
        self.layer_initializers = []  # per layer: (weight name, bias name or None)
        self.steps = []  # (op, inputs, output, attributes, constants, layer index or None)
        for node in g.node:
            attrs = {a.name: _onnx.helper.get_attribute_value(a) for a in node.attribute}
            consts = [init.get(name) for name in node.input]
            layer = None
            if node.op_type not in _OPS:
                raise _unsupported(path, node, "op not supported by xbarsim.onnx (supported: " + ", ".join(_OPS) + ")")
            if node.op_type in ("Conv", "Gemm") and consts[1] is None:
                raise _unsupported(path, node, "its weight is not an initializer")
            if node.op_type == "Conv":
                w = consts[1]
                pads = attrs.get("pads", [0, 0, 0, 0])
                if len(pads) != 4 or pads[0] != pads[2] or pads[1] != pads[3] or w.dim() != 4:
                    raise _unsupported(path, node, "only 2-D convolutions with symmetric pads are supported")
                if attrs.get("auto_pad", b"NOTSET") not in (b"NOTSET", "NOTSET"):
                    raise _unsupported(path, node, "auto_pad is not supported")
                conv = torch.nn.Conv2d(w.shape[1] * attrs.get("group", 1), w.shape[0], tuple(w.shape[2:]),
                                       stride=tuple(attrs.get("strides", [1, 1])), padding=tuple(pads[:2]),
                                       dilation=tuple(attrs.get("dilations", [1, 1])), groups=attrs.get("group", 1),
                                       bias=len(node.input) > 2)
                conv.weight.data = w.clone()
                if len(node.input) > 2:
                    conv.bias.data = consts[2].clone()
                layer = conv
            elif node.op_type == "Gemm":
                if attrs.get("transB", 0) != 1 or attrs.get("transA", 0) != 0 or attrs.get("alpha", 1.0) != 1.0 \
                        or attrs.get("beta", 1.0) != 1.0:
                    raise _unsupported(path, node, "only Gemm with transB = 1, transA = 0, alpha = beta = 1")
                w = consts[1]
                fc = torch.nn.Linear(w.shape[1], w.shape[0], bias=len(node.input) > 2)
                fc.weight.data = w.clone()
                if len(node.input) > 2:
                    fc.bias.data = consts[2].clone().reshape(-1)
                layer = fc
            if layer is not None:
                self.layers.append(layer)
                self.layer_initializers.append((node.input[1], node.input[2] if len(node.input) > 2 else None))
                layer = len(self.layers) - 1
            self.steps.append((node.op_type, list(node.input), node.output[0], attrs, consts, layer))

    @property
    def preprocessing(self):
        """(scale, mean, std) from metadata input_scale, input_mean, input_std (defaults 1/255, 0, 1)."""
        def numbers(key, default):
            text = self.metadata.get(key)
            if text is None:
                return default
            try:
                return [_fraction(v) for v in text.split(",")]
            except ValueError:
                raise ValueError(f"{self.path}: metadata '{key}' = '{text}' is not a list of numbers") from None
        scale = numbers("input_scale", [1 / 255])[0]
        return scale, numbers("input_mean", [0.0]), numbers("input_std", [1.0])

    def forward(self, x):
        env = {self.input_name: x}
        for op, ins, out, attrs, consts, layer in self.steps:
            a = env.get(ins[0])
            if op in ("Conv", "Gemm"):
                y = self.layers[layer](a)
            elif op == "Relu":
                y = F.relu(a)
            elif op == "Add":
                y = a + (env[ins[1]] if consts[1] is None else consts[1])
            elif op == "Slice":
                starts, ends = consts[1].tolist(), consts[2].tolist()
                axes = consts[3].tolist() if len(ins) > 3 else list(range(len(starts)))
                steps = consts[4].tolist() if len(ins) > 4 else [1] * len(starts)
                index = [slice(None)] * a.dim()
                for s, e, ax, st in zip(starts, ends, axes, steps):
                    if st <= 0:
                        raise ValueError(f"{self.path}: negative Slice steps are not supported")
                    index[ax] = slice(s, min(e, a.shape[ax]), st)
                y = a[tuple(index)]
            elif op == "Pad":
                pads = consts[1].tolist()
                value = float(consts[2]) if len(ins) > 2 and consts[2] is not None else 0.0
                n = a.dim()
                torch_pads = []
                for ax in reversed(range(n)):
                    torch_pads += [pads[ax], pads[ax + n]]
                y = F.pad(a, torch_pads, value=value)
            elif op == "MaxPool":
                pads = attrs.get("pads", [0, 0, 0, 0])
                y = F.max_pool2d(a, attrs["kernel_shape"], attrs.get("strides", attrs["kernel_shape"]), pads[:2],
                                 ceil_mode=bool(attrs.get("ceil_mode", 0)))
            elif op == "AveragePool":
                pads = attrs.get("pads", [0, 0, 0, 0])
                y = F.avg_pool2d(a, attrs["kernel_shape"], attrs.get("strides", attrs["kernel_shape"]), pads[:2],
                                 ceil_mode=bool(attrs.get("ceil_mode", 0)),
                                 count_include_pad=bool(attrs.get("count_include_pad", 0)))
            elif op == "GlobalAveragePool":
                y = a.mean(dim=(2, 3), keepdim=True)
            elif op == "Flatten":
                y = a.flatten(attrs.get("axis", 1))
                if y is a:  # a new value, as eval's Flatten (a layer after it does not read the input)
                    y = a.view(a.shape)
            elif op == "Reshape":
                y = a.reshape(a.shape[0], -1)
            env[out] = y
        return env[self.output_name]


def _fraction(text):
    """'1/255' or '0.5' as a float."""
    text = text.strip()
    if "/" in text:
        a, b = text.split("/", 1)
        return float(a) / float(b)
    return float(text)


def load(path):
    """The ONNX model at `path` as an OnnxModule (trainable; ValueError naming the file and node
    for what it cannot read)."""
    return OnnxModule(path)


def _atomic_write(path, write):
    """write(tmp) then rename onto path: an interrupted export leaves no partial file."""
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".xbarsim_export_", suffix=".onnx", dir=directory)
    os.close(fd)
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def export(model, path, metadata=None, sample=None):
    """Writes `model` as an ONNX file `xbarsim eval` runs, with its preprocessing metadata.

    A model read by load() (analog layers of xbarsim.nn too: they are Conv2d/Linear) is written as
    the graph it was read from with its layers' current weights and biases, float32, and the
    source's metadata_props updated by `metadata` ({key: value}; a value None deletes the key;
    software_accuracy_test_batch is dropped unless given, as it was measured on the old weights).
    Any other module is exported by torch.onnx.export (opset 13, input 'input' N x C x H x W from
    `sample`, output 'logits') with `metadata` as its metadata_props. The file is written whole
    or not at all (a temporary file renamed)."""
    metadata = dict(metadata or {})
    if isinstance(model, OnnxModule):
        proto = _onnx.ModelProto()
        proto.CopyFrom(model.source)
        by_name = {t.name: t for t in proto.graph.initializer}
        for layer, (w_name, b_name) in zip(model.layers, model.layer_initializers):
            for name, p in ((w_name, layer.weight), (b_name, layer.bias)):
                if name is None or p is None:
                    continue
                old = by_name[name]
                arr = p.detach().cpu().numpy().astype(np.float32).reshape(tuple(old.dims))
                old.CopyFrom(_numpy_helper.from_array(arr, name))
        props = {p.key: p.value for p in proto.metadata_props}
        props.pop("software_accuracy_test_batch", None)
        for k, v in metadata.items():
            if v is None:
                props.pop(k, None)
            else:
                props[k] = str(v)
        del proto.metadata_props[:]
        for k, v in props.items():
            entry = proto.metadata_props.add()
            entry.key, entry.value = k, v
        _atomic_write(path, lambda tmp: _onnx.save(proto, tmp))
        return
    if sample is None:
        raise ValueError("export: a model not read by xbarsim.onnx.load needs sample= (an input batch) to trace")

    def write(tmp):
        was = model.training
        model.eval()
        try:
            torch.onnx.export(model, sample, tmp, opset_version=13, input_names=["input"], output_names=["logits"],
                              dynamic_axes={"input": {0: "n"}, "logits": {0: "n"}})
        finally:
            model.train(was)
        proto = _onnx.load(tmp)
        for k, v in metadata.items():
            if v is not None:
                entry = proto.metadata_props.add()
                entry.key, entry.value = k, str(v)
        _onnx.save(proto, tmp)
    _atomic_write(path, write)
