"""load_results on the results folders shipped in the repository."""

import numpy as np
import pandas as pd
import pytest

import deformlab as dl

from conftest import REPO


def test_load_results_reads_the_tables():
    folder = REPO / "results" / "fig14"
    r = dl.load_results(folder)
    assert isinstance(r["cases"], pd.DataFrame) and isinstance(r["summary"], pd.DataFrame)
    assert isinstance(r["curves"], pd.DataFrame) and isinstance(r["manifest"], dict)
    assert {"case", "method"} <= set(r["cases"].columns)
    assert list(r["curves"].columns) == ["case", "case_id", "method", "curve", "x", "y"]
    raw = pd.read_csv(folder / "cases.csv")
    kp = [c for c in ("keypoints", "target_keypoints") if c in raw.columns]
    assert kp, "fig14 has key point columns"
    assert r["cases"].drop(columns=kp).equals(raw.drop(columns=kp))
    # Key points are int64 arrays, the CSV's "a;b;c" parsed.
    for c in kp:
        for got, text in zip(r["cases"][c], raw[c]):
            assert isinstance(got, np.ndarray) and got.dtype == np.int64
            want = [] if pd.isna(text) else [int(t) for t in str(text).split(";")]
            assert got.tolist() == want


def test_load_results_refuses_an_empty_folder(tmp_path):
    with pytest.raises(ValueError, match="no results"):
        dl.load_results(tmp_path)
