"""Issue 39 (items 3, 4 and 6): the package's rough edges. Each test failed before its fix."""
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

import xbarsim

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_star_import_leaves_the_builtin_eval():
    scope = {}
    exec("from xbarsim import *", scope)
    assert "eval" not in scope  # the builtin stays
    assert "Config" in scope and "simulate" in scope
    assert callable(xbarsim.eval)  # the wrapper, called qualified


def test_json_keyword_keeps_the_json(tmp_path):
    # "option --json is given twice" before: the wrapper added its own --json.
    out = tmp_path / "x.json"
    r = xbarsim.overhead(preset="resnet20", json=out)
    assert out.exists()
    import json
    assert json.loads(out.read_text())["layers"] == r["layers"]


def test_a_misspelled_keyword_is_a_type_error_naming_it():
    # Before: "--imags" went to the CLI, which called it an unknown option (a ValueError about a flag).
    with pytest.raises(TypeError, match="unexpected keyword argument 'imags'"):
        xbarsim.eval("lenet_mnist", imags=3)
    with pytest.raises(TypeError, match="unexpected keyword argument 'imgaes'"):
        xbarsim.simulate(preset="resnet20", imgaes=3)
    with pytest.raises(TypeError, match="unexpected keyword argument 'input_sizes'"):
        xbarsim.overhead(preset="resnet20", input_sizes="32,32")


def test_a_sweep_returns_a_list_and_the_docstrings_say_so():
    r = xbarsim.simulate(preset="lenet", timing_only=True, overrides={"converters.adc_bits": [6, 8]})
    assert isinstance(r, list) and len(r) == 2
    assert [p["sweep"]["converters.adc_bits"] for p in r] == ["6", "8"]
    assert isinstance(xbarsim.simulate(preset="lenet", timing_only=True), dict)
    for f in (xbarsim.eval, xbarsim.simulate, xbarsim.overhead, xbarsim.run):
        assert "list" in f.__doc__ and "sweep" in f.__doc__, f.__name__


def test_every_public_name_and_crossbar_attribute_has_a_docstring():
    for name in xbarsim.__all__ + ["eval"]:
        obj = getattr(xbarsim, name)
        if callable(obj):
            assert obj.__doc__ and len(obj.__doc__.strip()) > 20, name
    assert "converge" in xbarsim.SolverError.__doc__
    for attr in ("inputs", "outputs", "crossbars", "x_max", "signed_inputs", "reports", "matvec"):
        doc = getattr(xbarsim.Crossbar, attr).__doc__
        assert doc and len(doc.strip()) > 10, attr
    for f in (xbarsim.eval, xbarsim.simulate, xbarsim.overhead, xbarsim.explore):
        assert "Returns" in f.__doc__ and "keyword" in f.__doc__, f.__name__


def test_another_interpreter_is_told_which_one_the_extension_needs(tmp_path):
    # A copy of the package without a loadable extension stands in for another interpreter
    # (whose ABI tag the extension's file name does not match): the ImportError names the
    # interpreter the package was built for.
    pkg = os.path.dirname(xbarsim.__file__)
    copy = tmp_path / "xbarsim"
    shutil.copytree(pkg, copy, ignore=shutil.ignore_patterns("_core*", "__pycache__"))
    built = (copy / "_built_for.py").read_text()
    (copy / "_built_for.py").write_text(built.replace('VERSION = "', 'VERSION = "0.'))  # "another" version
    r = subprocess.run([sys.executable, "-c", "import xbarsim"], capture_output=True, text=True,
                       env={**os.environ, "PYTHONPATH": str(tmp_path)})
    assert r.returncode != 0
    assert "ImportError: xbarsim's extension (xbarsim._core) is built for /" in r.stderr, r.stderr
    assert sys.executable in r.stderr


def test_readme_names_the_interpreter_beside_the_command():
    readme = open(os.path.join(ROOT, "README.md")).read()
    for line in readme.splitlines():
        if "PYTHONPATH=build/python" in line:
            assert "/usr/bin/python3" in line, line


def test_output_errors_are_relative_to_the_layers_output_range():
    # The same hand values as the C++ test (tests/analog/test_converters.cpp): a quiet channel's
    # 0.05 is 0.005 of the layer's range 10, not 2500 of its own 2e-5.
    ideal = np.array([[0, 0], [5, 2e-5], [10, 0]])
    actual = np.array([[0.1, 0.05], [5, 0], [9.8, 0]])
    r = xbarsim.layer_output_range(np.array([0.0, 0.0]), np.array([10, 2e-5]))
    assert r == 10
    mean, worst, count = xbarsim.output_errors(actual, ideal, r)
    assert count == 6
    assert mean == pytest.approx((0.01 + 0.02 + 0.005 + 2e-6) / 6, abs=1e-15)
    assert worst == pytest.approx(0.02, abs=1e-15)
    with pytest.raises(ValueError, match="differ in shape"):
        xbarsim.output_errors(actual, ideal[:2], r)
