"""The emulated AS-i PC2 board: the device side of the DPRAM (docs/master.md).

``board`` is the card behind its three I/O registers; its parts are the AS-i cable
(``asi``), the master's execution control (``execution``), the host commands
(``commands``), AS-i Control (``control``) and the firmware blocks (``services``).
Nothing here imports the compiler: the board runs images, as the real firmware does.
"""
