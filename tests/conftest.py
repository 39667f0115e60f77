"""Test session set-up: one BLAS thread (batlab's matrices are small; on 2 cores extra BLAS
threads only contend with each other), and matplotlib without a display."""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MPLBACKEND", "Agg")
