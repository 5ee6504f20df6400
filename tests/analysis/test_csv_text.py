"""analysis.exports.write_csv: the bytes pandas' ``to_csv(index=False)`` writes, whichever path
formats them (the column-wise :func:`analysis.exports.csv_text`, or pandas itself)."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from analysis.exports import csv_text, write_csv

HARD_FLOATS = [0.0, -0.0, 1.0, -1.5, 0.1 + 0.2, 1 / 3, 2 / 3, 1e-5, 1e-4, 1e15, 1e16, 123456789.125,
               5e-324, 2.2250738585072014e-308, 1.7976931348623157e308, np.inf, -np.inf, np.nan,
               0.11666666666666668, 1e22, 9007199254740993.0, -2.5e-7]


def _pandas_bytes(df, tmp_path) -> bytes:
    ref = tmp_path / "pandas.csv"
    df.to_csv(ref, index=False)
    return ref.read_bytes()


def _frames():
    rng = np.random.default_rng(7)
    yield "hard floats", pd.DataFrame({"x_C": HARD_FLOATS, "y": HARD_FLOATS[::-1]})
    yield "negative zero only among zeros", pd.DataFrame({"a": [-0.0, 0.0, -0.0], "b": [1, 2, 3]})
    yield "ints and bools", pd.DataFrame({
        "i": np.array([0, -1, 2**62, -(2**63), 7] * 3, dtype=np.int64),
        "u": np.array([0, 1, 2**64 - 1, 5, 5] * 3, dtype=np.uint64),
        "small": np.array([1, 0, 1, 1, 0] * 3, dtype=np.int8),
        "flag": np.array([True, False, True, True, False] * 3)})
    yield "strings with gaps", pd.DataFrame({
        "name": ["printed", "skin", None, "", "Größe µm °C", np.nan],
        "v": np.arange(6, dtype=float) / 7})
    yield "pandas string dtype", pd.DataFrame({
        "name": pd.array(["a", pd.NA, "c d", ""], dtype="string"), "v": [1.5, 2.5, np.nan, 0.0]})
    yield "many repeated proportions", pd.DataFrame({
        "p": rng.integers(0, 181, 5000) / 180, "k": rng.integers(0, 3, 5000),
        "q": np.where(rng.random(5000) < 0.1, np.nan, rng.random(5000))})
    yield "no rows", pd.DataFrame({"a": pd.Series([], dtype=float), "b": pd.Series([], dtype=str)})
    yield "comma in a field", pd.DataFrame({"a": ["x,y", "z"], "b": [1, 2]})
    yield "quotes and commas in fields", pd.DataFrame({
        "setting": ['0.15 K, 0.15 K/s', 'say "hi"', '"', ',', '""', 'a,"b",c', None, "plain"] * 3,
        "v": np.arange(24, dtype=float) / 7})
    # left to pandas: a line break in a field or quoting in a name, one column, other dtypes
    yield "carriage return in a field", pd.DataFrame({"a": ["x\ry", "z,"], "b": [1.0, 2.0]})
    yield "quote in a name", pd.DataFrame({'say "hi"': [1, 2], "b": [1, 2]})
    yield "newline in a field", pd.DataFrame({"a": ["x\ny", "z"], "b": [1.0, 2.0]})
    yield "one column", pd.DataFrame({"a": [1.0, np.nan]})
    yield "nullable ints", pd.DataFrame({"a": pd.array([1, None], dtype="Int64"), "b": [1, 2]})
    yield "categories", pd.DataFrame({"a": pd.Categorical(["x", "y"]), "b": [1, 2]})
    yield "mixed objects", pd.DataFrame({"a": ["x", 1], "b": [1, 2]})
    yield "float32", pd.DataFrame({"a": np.array([0.1, 1 / 3], dtype=np.float32), "b": [1, 2]})


@pytest.mark.parametrize("label,df", list(_frames()), ids=[label for label, _ in _frames()])
def test_write_csv_writes_the_bytes_pandas_writes(label, df, tmp_path):
    out = write_csv(df, tmp_path / "table.csv")
    assert out.read_bytes() == _pandas_bytes(df, tmp_path)


def test_the_column_wise_path_takes_plain_tables_and_leaves_the_rest_to_pandas():
    taken = {label for label, df in _frames() if csv_text(df) is not None}
    assert taken == {"hard floats", "negative zero only among zeros", "ints and bools",
                     "strings with gaps", "pandas string dtype", "many repeated proportions",
                     "no rows", "comma in a field", "quotes and commas in fields"}
