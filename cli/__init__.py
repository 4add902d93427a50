"""The ``shbake`` command line: one thin click module per subcommand.

Threads (SPEC §6): shbake's kernels share the cores out themselves
(:func:`shbake.jit.run_blocks`, ``SHBAKE_THREADS``), so OpenBLAS gets one thread
unless ``OPENBLAS_NUM_THREADS`` says otherwise. This is set before numpy loads. A
second BLAS pool busy-waits against the kernels on a 2-core machine. Its threaded
products also sum in an order that depends on the thread count: on an AMD EPYC, a
probe fit's ``fit_stats`` differed in the last digit between a 2-thread process and a
1-thread Dask worker.
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
