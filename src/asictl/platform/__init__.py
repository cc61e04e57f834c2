"""Facts of the hardware asictl talks to, each defined once.

``master`` holds what every AS-i master with AS-i Control has (slave count, EEPROM, clock,
the AS-i Control flags byte, the [OPTIONS] names); ``pc2`` the PC2 board's DPRAM map and
host commands; ``gateway`` the Modbus gateway's register map; ``display`` its 7-segment rule.
Both the emulated devices and the host side import them, so they cannot drift apart.
"""
