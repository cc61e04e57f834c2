"""The emulated AS-i PC2 board and the host side that drives it through three I/O registers."""
