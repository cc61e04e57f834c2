"""Simulation: scenarios run on the emulated master in virtual time, with traces."""

#: What a scenario file's name ends with (here, so that finding scenarios, as the pytest
#: plugin does in every run, loads none of the simulation).
SUFFIX = ".scenario.toml"
