"""load_results on the results folders shipped in the repository."""

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
    assert r["cases"].equals(pd.read_csv(folder / "cases.csv"))


def test_load_results_refuses_an_empty_folder(tmp_path):
    with pytest.raises(ValueError, match="no results"):
        dl.load_results(tmp_path)
