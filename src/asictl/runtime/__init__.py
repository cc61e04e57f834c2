"""The runtime contract between compiled programs and the master's firmware (docs/runtime.md).

Both sides import it: the code generator links against ``layout`` and describes a
program's memory in a ``program_map``; the firmware (``runner``, used by the emulated
board) runs the program by that map and enters the ``firmware`` blocks it calls.
"""
