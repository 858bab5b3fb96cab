"""A torch module that computes an ONNX graph of the shared models' ops (Conv, Gemm, Relu, Add,
Slice, Pad, MaxPool, GlobalAveragePool, Flatten), for comparing xbarsim.torch with eval on the
same network. Conv and Gemm become Conv2d and Linear modules registered in graph order (the
order eval numbers its linear layers in); the rest is interpreted node by node."""
import onnx
import onnx.numpy_helper
import torch
import torch.nn.functional as F


class OnnxModule(torch.nn.Module):
    def __init__(self, path):
        super().__init__()
        model = onnx.load(path)
        g = model.graph
        self.metadata = {p.key: p.value for p in model.metadata_props}
        init = {t.name: torch.from_numpy(onnx.numpy_helper.to_array(t).copy()) for t in g.initializer}
        self.input_name, self.output_name = g.input[0].name, g.output[0].name
        self.layers = torch.nn.ModuleList()
        self.steps = []  # (op, inputs, output, attributes, constants, layer index or None)
        for node in g.node:
            attrs = {a.name: onnx.helper.get_attribute_value(a) for a in node.attribute}
            consts = [init.get(name) for name in node.input]
            layer = None
            if node.op_type == "Conv":
                w = consts[1]
                pads = attrs.get("pads", [0, 0, 0, 0])
                assert pads[0] == pads[2] and pads[1] == pads[3], "asymmetric Conv padding"
                conv = torch.nn.Conv2d(w.shape[1] * attrs.get("group", 1), w.shape[0], tuple(w.shape[2:]),
                                       stride=tuple(attrs.get("strides", [1, 1])), padding=tuple(pads[:2]),
                                       dilation=tuple(attrs.get("dilations", [1, 1])), groups=attrs.get("group", 1),
                                       bias=len(node.input) > 2)
                conv.weight.data = w.clone()
                if len(node.input) > 2:
                    conv.bias.data = consts[2].clone()
                layer = conv
            elif node.op_type == "Gemm":
                assert attrs.get("transB", 0) == 1 and attrs.get("transA", 0) == 0
                assert attrs.get("alpha", 1.0) == 1.0 and attrs.get("beta", 1.0) == 1.0
                w = consts[1]
                fc = torch.nn.Linear(w.shape[1], w.shape[0], bias=len(node.input) > 2)
                fc.weight.data = w.clone()
                if len(node.input) > 2:
                    fc.bias.data = consts[2].clone()
                layer = fc
            elif node.op_type not in ("Relu", "Add", "Slice", "Pad", "MaxPool", "GlobalAveragePool", "Flatten"):
                raise ValueError(f"onnx_torch: op {node.op_type} is not supported")
            if layer is not None:
                self.layers.append(layer)
                layer = len(self.layers) - 1
            self.steps.append((node.op_type, list(node.input), node.output[0], attrs, consts, layer))

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
                    assert st > 0, "negative Slice steps are not supported"
                    index[ax] = slice(s, min(e, a.shape[ax]), st)
                y = a[tuple(index)]
            elif op == "Pad":
                pads = consts[1].tolist()
                assert attrs.get("mode", b"constant") in (b"constant", "constant")
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
            elif op == "GlobalAveragePool":
                y = a.mean(dim=(2, 3), keepdim=True)
            elif op == "Flatten":
                y = a.flatten(attrs.get("axis", 1))
            env[out] = y
        return env[self.output_name]
