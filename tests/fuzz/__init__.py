"""The fuzz suite of issue 18: random models, scenes, recording choices and study definitions
through the public API, each case run in a worker process with a time and a memory limit, every
outcome classified (see :mod:`fuzz.harness`). ``tests/test_fuzz.py`` runs a fixed-seed slice in
CI; ``scripts/fuzz.py`` runs the long campaign."""
