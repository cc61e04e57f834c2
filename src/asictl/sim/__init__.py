"""Simulation: scenarios run on the emulated master in virtual time, with traces."""
