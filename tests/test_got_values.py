"""Error messages show a bad argument's value as a plain number (DESIGN §7).

numpy 2 scalars repr as ``np.float64(-1.0)`` and 0-d arrays as ``array(-1.)``; a message
naming the argument should say ``got -1.0``.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import harness
import harness.corpus
import motions
import scenes
from harness import Box, RepairError, Sphere
from harness.avoid import colliding_cases
from motions._checks import short


def _line():
    return motions.interpolate([[1, 0, 0, 0]] * 3, [[0, 0, 0], [1, 0, 0], [2, 0, 0]])


CASES = [
    (
        lambda: harness.ground_truth(
            _line(),
            Sphere(0.1),
            [Box([0.1, 0.1, 0.1], center=[0, 3, 0])],
            resolution=np.float64(-1.0),
        ),
        ValueError,
        "`resolution`",
        "-1.0",
    ),
    (
        lambda: harness.repair(*_colliding(), clearance=np.float64(-1.0)),
        RepairError,
        "`clearance`",
        "-1.0",
    ),
    (lambda: harness.render("slot", frames=np.int64(0)), ValueError, "`frames`", "0"),
    (lambda: harness.render("slot", frames=np.float64(2.5)), ValueError, "`frames`", "2.5"),
    (
        lambda: harness.render("slot", control_segment=np.float64(1.5)),
        TypeError,
        "`control_segment`",
        "1.5",
    ),
    (lambda: harness.corpus.generate(size=np.float64(-1.0)), ValueError, "`size`", "-1.0"),
    (lambda: scenes.load("clutter", seed=np.float64(1.5)), scenes.SceneError, "`seed`", "1.5"),
    (lambda: Sphere(-1.0), harness.ShapeError, "`radius`", "-1.0"),
    (lambda: Sphere(np.float64(-2.0)), harness.ShapeError, "`radius`", "-2.0"),
    (
        lambda: harness.certify(_line(), Sphere(0.1), [], tolerance=np.float64(-1.0)),
        ValueError,
        "`tolerance`",
        "-1.0",
    ),
]


def _colliding():
    case = colliding_cases(1, seed=3)[0]
    return case.motion, case.body, case.obstacles


@pytest.mark.parametrize(("call", "error", "name", "got"), CASES)
def test_messages_show_plain_numbers(call, error, name, got):
    with pytest.raises(error) as e:
        call()
    msg = str(e.value)
    assert name in msg, msg
    assert re.search(rf"got {re.escape(got)}\b", msg), msg
    assert "np." not in msg and "array(" not in msg, msg


def test_short_prints_numpy_scalars_and_0d_arrays_plainly():
    assert short(np.float64(-1.0)) == "-1.0"
    assert short(np.array(-1.0)) == "-1.0"
    assert short(np.int64(3)) == "3"
    assert short(np.str_("cpu")) == "'cpu'"
    assert short(np.array([1.0, 2.0])) == "[1. 2.]"


NUMBER_ARGS = [
    (lambda v: motions.darboux(radius=v), "`radius`"),
    (lambda v: motions.darboux(phase=v), "`phase`"),
    (lambda v: _line().speed_bound(0.0, 1.0, v), "`radius`"),
    (lambda v: harness.corpus.generate(size=v), "`size`"),
    (
        lambda v: harness.ground_truth(_line(), Sphere(0.1), [Box([0.1, 0.1, 0.1])], resolution=v),
        "`resolution`",
    ),
]


@pytest.mark.parametrize(("call", "name"), NUMBER_ARGS)
@pytest.mark.parametrize(("value", "got"), [("0.5", "'0.5'"), (True, "True"), ([1, 2], "[1 2]")])
def test_number_arguments_refuse_strings_bools_and_lists(call, name, value, got):
    # one checker (motions._checks.as_float): a string or bool is not silently a number
    with pytest.raises(TypeError) as e:
        call(value)
    msg = str(e.value)
    assert name in msg and msg.endswith(f"got {got}."), msg


@pytest.mark.parametrize(("call", "name"), NUMBER_ARGS[:3])
def test_number_arguments_take_numpy_scalars(call, name):
    # numpy scalars are numbers (the result is a motion or a float, not an error)
    assert call(np.float64(0.5)) is not None


@pytest.mark.parametrize(
    "fn, typo, says",
    [
        (harness.certify, "tolerence", "certify() got an unexpected keyword argument 'tolerence'; did you mean 'tolerance'?"),
        (harness.certify, "max_node", "did you mean 'max_nodes'?"),
        (harness.clearance, "max_dept", "clearance() got an unexpected keyword argument 'max_dept'; did you mean 'max_depth'?"),
        (harness.clearance, "clearance", "clearance() got an unexpected keyword argument 'clearance' (its keywords: tolerance, max_depth,"),
        (harness.repair, "max_node", "repair() got an unexpected keyword argument 'max_node'; did you mean 'max_nodes'?"),
        (harness.certify_pair, "tolerence", "certify_pair() got an unexpected keyword argument 'tolerence'; did you mean 'tolerance'?"),
    ],
)  # fmt: skip
def test_a_misspelt_keyword_names_the_function_called(fn, typo, says):
    """A new user's trial: ``certify(..., tolerence=...)`` read "certify_many() got an
    unexpected keyword", and clearance's was raised from inside contextlib (a review:
    certify_pair's named certify, repair's named no function)."""
    args = (_line(), Sphere(0.1))
    args += (
        (_line(), Box([0.1] * 3))
        if fn is harness.certify_pair
        else ([Box([0.1] * 3, center=[0, 3, 0])],)
    )
    with pytest.raises(TypeError) as e:
        fn(*args, **{typo: 1e-3})
    assert says in str(e.value)
    assert e.traceback[-1].path.name == "api.py"  # (raised by the check, not inside a call)


def test_query_error_is_public():
    with pytest.raises(harness.QueryError, match="Expected"):
        harness.certify(_line(), Sphere(0.1), [Box([0.1, 0.1, 0.1])], bound="sampled", samples=1)
