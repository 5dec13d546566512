"""The examples in fcol's docstrings run and print what they say."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import fcol


def _modules():
    names = ["fcol"]
    for m in pkgutil.walk_packages(fcol.__path__, "fcol."):
        if m.name.startswith(("fcol.bench.", "fcol.demo.")) or m.name.endswith("__main__"):
            continue
        names.append(m.name)
    return names


@pytest.mark.parametrize("name", _modules())
def test_module_docstring_examples(name):
    mod = importlib.import_module(name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    for test in finder.find(mod, name):
        runner.run(test)
    res = runner.summarize(verbose=False)
    assert res.failed == 0


def test_native_docstring_examples():
    """Classes of the extension module, their methods and properties carry
    examples too."""
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    finder = doctest.DocTestFinder(exclude_empty=True)
    n = 0
    for name in dir(fcol._fcol):
        obj = getattr(fcol._fcol, name)
        if not isinstance(obj, type):
            continue
        # The class's own examples, then those of its methods and properties.
        docs = [(f"fcol._fcol.{name}", obj.__doc__)]
        docs += [(f"fcol._fcol.{name}.{k}", getattr(v, "__doc__", None)) for k, v in vars(obj).items()]
        for label, doc in docs:
            if not (isinstance(doc, str) and ">>>" in doc):
                continue
            for test in finder.find(doc, label, globs={"fcol": fcol}):
                runner.run(test)
                n += len(test.examples)
    assert n > 0
    assert runner.summarize(verbose=False).failed == 0


def test_build_description():
    # What the bench prints beside its timings: the build's profile and the
    # instruction sets it was compiled for (a build for this machine's
    # processor names those of the machine).
    assert fcol.build_profile in ("debug", "release")
    assert isinstance(fcol.build_features, str)
    known = {"sse4.2", "avx2", "fma", "avx512f", "neon"}
    assert set(fcol.build_features.split()) <= known
    if "avx512f" in fcol.build_features.split():
        assert "avx2" in fcol.build_features.split()
