"""ipyros benchmarks: ``python -m bench`` (or ``bash run.sh bench``) runs them all and prints tables."""
