"""Emulated AS-i/Modbus gateway (VAG-MOD-KF-R4) and its user-defined Modbus functions."""
