"""The emulated AS-i PC2 board: the device side of the DPRAM (docs/master.md).

``board`` is the card behind its three I/O registers, with time and the AS-i cycle; its
parts are the DPRAM (``dpram``), the AS-i cable (``asi``), the master's execution control
(``execution``), AS-i Control (``control``), the firmware blocks (``services``), the
images the master writes into the DPRAM (``images``), the host commands (``commands``)
and what survives power-off (``nonvolatile``). Nothing here imports the compiler: the
board runs images, as the real firmware does.
"""
