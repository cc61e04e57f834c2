"""Proving properties of IL programs and comparing two versions of one.

``props`` reads properties files; ``symbolic`` is the program cycle as z3 terms, built
from the reference interpreter's rules; ``engine`` decides properties (bounded model
checking for counterexamples and witnesses, k-induction strengthened with invariants it
finds for proofs); ``counterexample`` writes what it finds as scenarios; ``diff``
compares two programs network by network and decides whether they behave the same.
"""
