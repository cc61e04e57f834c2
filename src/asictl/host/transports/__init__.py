"""The ways to a master's registers and functions, below the commands.

``driver`` reaches a PC2 board's three I/O registers (/dev/port, an emulated board) and
runs its commands as ``jobs``; ``modbus`` is the gateway's transport over pymodbus, with
its own functions in ``gateway_pdus`` and its address (``--modbus``) in ``target``. The
commands (host/transfer.py, host/status.py, ...) are written against these, and
host/connection.py chooses one.
"""
