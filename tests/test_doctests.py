"""The examples in the public docstrings run and print what they claim."""

import doctest

import pytest

import hybrid.engine.simulate
import hybrid.integrators.registry
import hybrid.model.linear
import hybrid.model.plot_hints
import hybrid.model.system
import hybrid.orbits.autonomous
import hybrid.studies.sweep
import hybrid_models.averaging
import hybrid_models.overlays

MODULES = [
    hybrid.orbits.autonomous,
    hybrid.engine.simulate,
    hybrid.integrators.registry,
    hybrid.studies.sweep,
    hybrid.model.system,
    hybrid.model.linear,
    hybrid.model.plot_hints,
    hybrid_models.overlays,
    hybrid_models.averaging,
]


@pytest.mark.parametrize("module", MODULES, ids=lambda m: m.__name__)
def test_docstring_examples(module):
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0
    assert result.attempted > 0
