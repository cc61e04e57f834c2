"""Seeing what an IL program does on the emulated master, line by line: where in the IL
source the 8051 is (``locate``), operands as the program sees them (``operands``,
``view``), hooks at the start of every IL line (``hooks``), per-line traces
(``iltrace``) and one cycle's line values on a live board (``online``).

Below the simulation, the debugger and the monitor, which all look through it."""
