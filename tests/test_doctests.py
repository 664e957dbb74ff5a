"""The examples in the public docstrings run and print what they claim."""

import doctest

import pytest

import hybrid._autonomous
import hybrid._linear
import hybrid._plothints
import hybrid._simulate
import hybrid._sweep
import hybrid._system
import hybrid_models.averaging
import hybrid_models.overlays

MODULES = [
    hybrid._autonomous,
    hybrid._simulate,
    hybrid._sweep,
    hybrid._system,
    hybrid._linear,
    hybrid._plothints,
    hybrid_models.overlays,
    hybrid_models.averaging,
]


@pytest.mark.parametrize("module", MODULES, ids=lambda m: m.__name__)
def test_docstring_examples(module):
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0
    assert result.attempted > 0
