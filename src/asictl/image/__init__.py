"""The program image: what a compiled program is on the master's EEPROM (``eeprom``)."""
