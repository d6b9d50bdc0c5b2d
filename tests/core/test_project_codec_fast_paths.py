"""The project codec's fast paths (tuples of plain numbers, texts, booleans read and written at
once) give what the item-by-item path gives, and bad items still get the item-by-item message.

The reference is the decode of each item alone through `Reader.decode(float | str | bool, …)`:
a tuple's fast path must equal the tuple of those."""

from __future__ import annotations

import math
import re

import pytest

from app.core.projects.codec import MAX_TEXT_CHARS, ProjectError, Reader, encode


def _reader() -> Reader:
    return Reader(blob=lambda name: b"")


@pytest.mark.parametrize(
    ("tp", "item_tp", "data"),
    [
        (tuple[float, ...], float, [1, 2.5, -3.0, 0, 1e300]),
        (tuple[str, ...], str, ["hip", "knee", ""]),
        (tuple[bool, ...], bool, [True, False, True]),
        (tuple[float, ...], float, []),
    ],
)
def test_fast_paths_equal_the_items_decoded_one_by_one(tp, item_tp, data):
    reader = _reader()
    got = reader.decode(tp, data, "x")
    expected = tuple(reader.decode(item_tp, item, f"x[{i}]") for i, item in enumerate(data))
    assert got == expected
    assert [type(v) for v in got] == [type(v) for v in expected]


@pytest.mark.parametrize(
    ("tp", "data", "where"),
    [
        (tuple[float, ...], [1.0, "a"], "x[1]"),
        (tuple[float, ...], [1.0, True], "x[1]"),  # a boolean is no number
        (tuple[float, ...], [1.0, math.inf], "x[1]"),
        (tuple[str, ...], ["a", 3], "x[1]"),
        (tuple[str, ...], ["a", "b" * (MAX_TEXT_CHARS + 1)], "x[1]"),
        (tuple[bool, ...], [True, 1], "x[1]"),
    ],
)
def test_a_bad_item_is_named_as_before(tp, data, where):
    with pytest.raises(ProjectError, match="^" + re.escape(where) + " "):
        _reader().decode(tp, data, "x")


def test_encoding_plain_numbers_at_once_equals_item_by_item():
    values = (0.5, -2.0, 1e-300)
    assert encode(values, "v", {}) == [encode(v, f"v[{i}]", {}) for i, v in enumerate(values)]
    # A non-finite number keeps its tagged form.
    assert encode((1.0, math.nan), "v", {}) == [1.0, {"float": "nan"}]
