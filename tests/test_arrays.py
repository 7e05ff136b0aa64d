"""circuitnsds.arrays.sorted_unique against numpy's np.unique, which it replaces on the
run path (np.unique imports numpy.ma on its first call)."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from circuitnsds.arrays import sorted_unique

floats = st.floats(allow_nan=False, width=64) | st.sampled_from([0.0, -0.0, 1e-300, 5e-324])


@given(hnp.arrays(np.float64, st.integers(0, 40), elements=floats))
def test_sorted_unique_is_np_unique(values):
    ours, numpys = sorted_unique(values), np.unique(values)
    assert ours.shape == numpys.shape
    assert np.array_equal(ours, numpys)  # ±0 are one value in both (0.0 == -0.0)


@given(hnp.arrays(np.int64, st.integers(0, 40), elements=st.integers(-5, 5)))
def test_sorted_unique_of_integers(values):
    assert np.array_equal(sorted_unique(values), np.unique(values))
    assert sorted_unique(values).dtype == values.dtype


def test_a_run_path_call_does_not_import_numpy_ma():
    import subprocess
    import sys

    code = ("import sys, numpy as np\nfrom circuitnsds.arrays import sorted_unique\n"
            "sorted_unique(np.array([3.0, 1.0, 3.0]))\nprint('numpy.ma' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.stdout.strip() == "False", done.stderr
