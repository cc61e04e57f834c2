"""How good the tests are: mutation testing of programs against their scenarios.

Coverage is collected where the cycles run (``observe/coverage.py``) and reported with the
scenarios (``sim/coverage.py``); judging a test suite by changing the program needs the
whole simulator and, for equivalent mutants, the prover, so it sits above both.
"""
