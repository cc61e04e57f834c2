"""The emulated PC2 boards the commands reach when no real one is there.

``boards`` keeps each board's non-volatile state in a file of the state directory
between commands (``state_files``: as private as ``~/.ssh``) under a lock that names its
holder (``locking``); ``actions`` is what only an emulated board can do (its AS-i cable,
its set button, the program's timers and counters), the same for a board loaded from its
state file and a live one (host/live/).
"""
