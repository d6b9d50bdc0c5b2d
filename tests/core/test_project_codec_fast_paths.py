"""The project codec's fast paths (tuples of plain numbers, texts, booleans read and written at
once) give what the item-by-item path gives, and bad items still get the item-by-item message.

The reference is the decode of each item alone through `Reader.decode(float | str | bool, …)`:
a tuple's fast path must equal the tuple of those."""

from __future__ import annotations

import math
import re

import numpy as np
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


@pytest.mark.parametrize(
    "values",
    [
        ["ok", "ok", "unsolved"],  # a feed-forward's sample statuses
        [3, True, "a", 0.25, -7],
        [1.0, np.float64(2.0), np.int64(3), np.bool_(False)],  # numpy scalars: item by item
        ["a", math.inf],
        [],
    ],
)
def test_encoding_plain_lists_at_once_equals_item_by_item(values):
    expected = [encode(v, f"v[{i}]", {}) for i, v in enumerate(values)]
    got = encode(values, "v", {})
    assert got == expected
    assert [type(v) for v in got] == [type(v) for v in expected]  # JSON writes 1 and 1.0 apart


def _npy(array, version=None) -> bytes:
    import io

    import numpy as np

    buffer = io.BytesIO()
    np.lib.format.write_array(buffer, array, version=version, allow_pickle=False)
    return buffer.getvalue()


@pytest.mark.parametrize("version", [(1, 0), (2, 0)])
def test_an_npy_header_read_by_the_pattern_gives_what_numpy_reads(version):
    import io

    import numpy as np

    from app.core.projects.codec import read_npy

    arrays = [
        np.arange(12.0).reshape(3, 4),
        np.arange(5) > 2,
        np.array(7, dtype=np.int64),
        np.zeros((2, 0)),
        np.asfortranarray(np.arange(6.0).reshape(3, 2)),
        np.arange(3, dtype=np.uint8),
        np.arange(3, dtype=">f4"),
    ]
    for array in arrays:
        raw = _npy(array, version)
        expected = np.load(io.BytesIO(raw), allow_pickle=False)  # numpy's own reader
        got = read_npy(raw, "x")
        assert got.dtype == expected.dtype and got.shape == expected.shape
        assert np.array_equal(got, expected)


def test_a_header_np_save_does_not_write_goes_to_numpys_parser_and_a_bad_one_is_refused():
    import io

    import numpy as np

    from app.core.projects.codec import read_npy

    raw = _npy(np.arange(4.0))
    header_size = int.from_bytes(raw[8:10], "little")
    body = raw[10 + header_size :]

    def with_header(text: str) -> bytes:
        text = text.ljust(header_size - 1) + "\n"
        return raw[:10] + text.encode("latin1") + body

    reordered = with_header("{'shape': (4,), 'fortran_order': False, 'descr': '<f8'}")
    assert np.array_equal(read_npy(reordered, "x"), np.load(io.BytesIO(reordered)))
    with pytest.raises(ProjectError, match="^x: not a readable array"):
        read_npy(with_header("{'descr': '<f8', 'shape': (4,)}"), "x")  # no fortran_order
    with pytest.raises(ProjectError, match="^x: its header declares shape"):
        read_npy(
            with_header("{'descr': '<f8', 'fortran_order': False, 'shape': (9999999999,), }"), "x"
        )
