"""The examples in the docstrings run, and a contiguous cloud is handed to Rust without a copy."""

import doctest

import numpy as np
import pytest

import pmon
import pmon._inputs
import pmon._params
import pmon.campaign


@pytest.mark.parametrize("module", [pmon, pmon._params, pmon.campaign])
def test_docstring_examples(module):
    failed, attempted = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert attempted > 0 and failed == 0


def test_a_contiguous_float32_cloud_is_passed_as_is():
    pts = np.zeros((10, 3), dtype=np.float32)
    assert pmon._inputs.points_array(pts) is pts
    four = np.zeros((10, 4), dtype=np.float32)
    assert pmon._inputs.points_array(four) is four
    strided = four[:, :3]
    out = pmon._inputs.points_array(strided)
    assert out is not strided and out.flags.c_contiguous
