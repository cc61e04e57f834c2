"""Seeing what an IL program does on the emulated master: where in the IL source the 8051
is (``locate``), operands as the program sees them (``view``), per-line traces
(``iltrace``) and the interactive debugger (``debugger``)."""
