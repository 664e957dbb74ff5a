"""The examples in the public docstrings run and print what they claim.

Every module of ``hybrid`` and ``hybrid_models`` whose docstrings hold an example that runs (not
all ``+SKIP``) is found by walking the packages, so that a new example is never left untested.
"""

import doctest
import importlib
import pkgutil
import types

import pytest

import hybrid
import hybrid_models

OPTIONS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def _runs_an_example(module) -> bool:
    """Whether ``module``'s docstrings hold an example that doctest attempts (not skipped)."""
    return any(
        not example.options.get(doctest.SKIP, OPTIONS & doctest.SKIP)
        for test in doctest.DocTestFinder().find(module)
        for example in test.examples
    )


def _modules_with_examples() -> list:
    found = []
    for package in (hybrid, hybrid_models):
        for info in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
            if info.name.rsplit(".", 1)[-1] == "__main__":  # importing it runs the program
                continue
            module = importlib.import_module(info.name)
            if _runs_an_example(module):
                found.append(module)
    return found


MODULES = _modules_with_examples()


def test_the_walk_finds_the_packages_examples():
    names = {m.__name__ for m in MODULES}
    assert {"hybrid.model.system", "hybrid.studies.sweep", "hybrid_models.averaging"} <= names, names


def test_a_module_whose_only_example_is_skipped_is_not_collected():
    module = types.ModuleType("skipped_only")
    exec('def f():\n    """\n    >>> f()  # doctest: +SKIP\n    """\n', module.__dict__)
    assert not _runs_an_example(module)
    exec('def g():\n    """\n    >>> 1 + 1\n    2\n    """\n', module.__dict__)
    assert _runs_an_example(module)


@pytest.mark.parametrize("module", MODULES, ids=lambda m: m.__name__)
def test_docstring_examples(module):
    result = doctest.testmod(module, optionflags=OPTIONS)
    assert result.failed == 0
    assert result.attempted > 0
