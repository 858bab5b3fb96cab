"""Issue 27: the shared LeNet and ResNet-20, read into torch and converted by xbarsim.torch,
predict as eval predicts on the same images (eval's journal records its classes). Both program
every layer alike: the same rows on the crossbars (eval's im2col order), input ranges and
calibration vectors (eval's picks, from calibration.seed) and salts. What is left differs only by
float rounding between torch's and xbarsim's software ops (summation order, pooling in float vs
double), which moves a few DAC/ADC codes. Skipped without the shared data or onnx."""
import gzip
import json
import os
import pathlib

import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="python3-torch not installed")
pytest.importorskip("onnx", reason="python3-onnx not installed")
import xbarsim  # noqa: E402
import xbarsim.torch as xtorch  # noqa: E402
from onnx_torch import OnnxModule  # noqa: E402


def shared_dir():
    data = os.environ.get("XBARSIM_DATA_DIR") or str(pathlib.Path(__file__).resolve().parents[2] / ".." / "shared" / "data")
    if not os.path.isdir(data):
        pytest.skip("shared data directory not found (set XBARSIM_DATA_DIR or place ../shared/data beside the "
                    "repository); test skipped")
    return pathlib.Path(data)


def preprocess(pixels, metadata):
    """eval's preprocessing: x = (pixel * scale - mean) / std in double, then float32."""
    num, den = metadata["input_scale"].split("/")
    scale = float(num) / float(den)
    mean = np.array([float(v) for v in metadata["input_mean"].split(",")]).reshape(1, -1, 1, 1)
    std = np.array([float(v) for v in metadata["input_std"].split(",")]).reshape(1, -1, 1, 1)
    return torch.from_numpy(((pixels.astype(np.float64) * scale - mean) / std).astype(np.float32))


def cifar10(path, count):
    raw = np.fromfile(path, np.uint8).reshape(-1, 3073)[:count]
    return raw[:, 1:].reshape(-1, 3, 32, 32), raw[:, 0].astype(np.int64)


def mnist(directory, first, count):
    with gzip.open(directory / "t10k-images-idx3-ubyte.gz") as f:
        images = np.frombuffer(f.read(), np.uint8, offset=16).reshape(-1, 1, 28, 28)
    with gzip.open(directory / "t10k-labels-idx1-ubyte.gz") as f:
        labels = np.frombuffer(f.read(), np.uint8, offset=8).astype(np.int64)
    return images[first:first + count], labels[first:first + count]


# (model, dataset, test images, calibration images (eval's calibration split, first 200)).
CASES = {
    "lenet": ("lenet_mnist.onnx", "mnist", lambda d, n: mnist(d / "mnist", 0, n), lambda d, n: mnist(d / "mnist", 9000, n)),
    "resnet20": ("resnet20_cifar10.onnx", "cifar10", lambda d, n: cifar10(d / "cifar10" / "test_batch.bin", n),
                 lambda d, n: cifar10(d / "cifar10" / "calib_batch.bin", n)),
}


def assert_only_ties_differ(logits, ours, theirs, most, tie):
    """At most `most` predictions differ, and each only where our logits are near a tie: the top
    two within `tie` of the image's logit spread (float rounding moves a few DAC/ADC codes; a
    wrong mapping or readout moves clear predictions too)."""
    differ = np.nonzero(ours != theirs)[0]
    top = logits.sort(dim=1, descending=True).values
    margin = ((top[:, 0] - top[:, 1]) / (top[:, 0] - top[:, -1])).numpy()
    assert len(differ) <= most, f"differ at images {differ.tolist()} (margins {margin[differ].round(4).tolist()})"
    assert (margin[differ] < tie).all(), f"clear predictions differ: images {differ.tolist()}, margins " \
                                         f"{margin[differ].round(4).tolist()} of the logit spread"


@pytest.mark.parametrize("case", sorted(CASES))
def test_converted_predictions_agree_with_eval(case, tmp_path):
    data = shared_dir()
    file, dataset, test_images, calib_images = CASES[case]
    model_path = data.parent / "models" / file
    if not model_path.exists():
        pytest.skip(f"{model_path} not found; test skipped")
    images, calibration = 500, 200  # eval.calibration_images' default
    net = OnnxModule(str(model_path)).eval()
    x, labels = test_images(data, images)
    x = preprocess(x, net.metadata)
    cx = preprocess(calib_images(data, calibration)[0], net.metadata)

    journal = tmp_path / "journal.jsonl"
    result = xbarsim.eval(str(model_path), dataset=dataset, images=images, journal=str(journal))
    rows = sorted((json.loads(line) for line in journal.read_text().splitlines()), key=lambda r: r["image"])
    assert [r["image"] for r in rows] == list(range(images))
    eval_classes = np.array([r["xb_class"] for r in rows])
    assert np.array_equal(eval_classes == labels, np.array([r["xb"] == 1 for r in rows]))

    analog = xtorch.convert(net, xbarsim.Config(), calibration=torch.utils.data.DataLoader(cx, batch_size=100))
    with torch.no_grad():
        logits = torch.cat([analog(x[i:i + 100]) for i in range(0, images, 100)])
    ours = logits.argmax(1).numpy()
    agree = int((ours == eval_classes).sum())
    print(f"{case}: {agree} of {images} predictions agree with eval's (eval {result['crossbar_accuracy']:.3f}, "
          f"converted {(ours == labels).mean():.3f})")
    # measured with 200 calibration vectors per crossbar (calibration.samples): ResNet-20 3 of 500
    # differ, at margins of 0.2-1.4 % of the logit spread (10 vectors: 1); LeNet none
    assert_only_ties_differ(logits, ours, eval_classes, most=5, tie=0.02)


def test_fine_tuned_export_agrees_with_eval(tmp_path):
    """Issue 41: a ResNet-20 fine-tuned by xbarsim.hwa (16 HWA steps under rram-wan2022) and
    exported by xbarsim.onnx: its software logits are the torch model's, and eval on the file
    predicts as xbarsim.inference on the torch model, image by image, with the device's
    programming error and read noise on."""
    import xbarsim.data as xdata
    import xbarsim.hwa as hwa
    import xbarsim.inference as inference
    import xbarsim.nn as xnn
    import xbarsim.onnx as xonnx
    data = shared_dir()
    model_path = data.parent / "models" / "resnet20_cifar10.onnx"
    train_file = data / "cifar10" / "data_batch_1.bin"
    if not model_path.exists() or not train_file.exists():
        pytest.skip("the shared ResNet-20 or data_batch_1.bin not found; test skipped")
    overrides = {"device.model": "rram-wan2022", "mapping.negative": "differential"}
    net = xonnx.load(model_path)
    train = xdata.Cifar10(files=[train_file], preprocessing=net.preprocessing, limit=2048)
    hw = xnn.Hardware(overrides)
    calibration = train.preprocess(train.images[:200])
    analog = xnn.convert(net, hw, calibration=calibration)
    hwa.fine_tune(analog, hw, train, epochs=1, calibration=calibration)  # 16 steps: clipped, adapting
    tuned = xnn.to_software(analog).eval()
    out = tmp_path / "tuned.onnx"
    xonnx.export(tuned, out)
    images = 500
    x, labels = cifar10(data / "cifar10" / "test_batch.bin", images)
    x = preprocess(x, net.metadata)
    reread = xonnx.load(out)
    with torch.no_grad():
        want, got = tuned(x[:100]), reread(x[:100])
    assert torch.allclose(got, want, rtol=1e-4, atol=1e-4 * float(want.abs().max()))
    assert not torch.equal(reread.layers[0].weight, net.layers[0].weight)

    journal = tmp_path / "journal.jsonl"
    result = xbarsim.eval(str(out), dataset="cifar10", images=images, journal=str(journal), overrides=overrides)
    rows = sorted((json.loads(line) for line in journal.read_text().splitlines()), key=lambda r: r["image"])
    eval_classes = np.array([r["xb_class"] for r in rows])
    cx = preprocess(cifar10(data / "cifar10" / "calib_batch.bin", 200)[0], net.metadata)
    exact = inference.convert(reread.eval(), xbarsim.Config(overrides=overrides),
                              calibration=torch.utils.data.DataLoader(cx, batch_size=100))
    with torch.no_grad():
        logits = torch.cat([exact(x[i:i + 100]) for i in range(0, images, 100)])
    ours = logits.argmax(1).numpy()
    agree = int((ours == eval_classes).sum())
    print(f"fine-tuned: {agree} of {images} predictions agree with eval's (eval {result['crossbar_accuracy']:.3f})")
    # float rounding moves a few DAC/ADC codes, as for the shared models above; under the device's
    # noise more predictions sit near a tie (measured with 10 calibration vectors: this model 498
    # of 500, scripts/hwa_study.py's HWA models 498 and 499, the original ResNet-20 under
    # rram-wan2022 492; with 200, this model 496)
    assert_only_ties_differ(logits, ours, eval_classes, most=6, tie=0.03)
