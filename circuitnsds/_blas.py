"""One BLAS thread, set before numpy loads its BLAS (imported first by the package).

Every matrix circuitnsds factorises is small; a multi-threaded OpenBLAS on a busy
2-core machine was measured 170x slower on a 300x300 LU (threads spinning). This
takes effect when circuitnsds is imported before numpy; set the variables
yourself to override it.
"""

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")
