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
    """Classes of the extension module carry examples too."""
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    finder = doctest.DocTestFinder(exclude_empty=True)
    n = 0
    for name in dir(fcol._fcol):
        obj = getattr(fcol._fcol, name)
        if isinstance(obj, type) and obj.__doc__ and ">>>" in obj.__doc__:
            for test in finder.find(obj.__doc__, f"fcol._fcol.{name}", globs={"fcol": fcol}):
                runner.run(test)
                n += len(test.examples)
    assert n > 0
    assert runner.summarize(verbose=False).failed == 0
