"""The host side: reaching a master and doing ACF's and ASI_MON's work through it.

``driver`` and ``jobs`` speak the PC2's register interface and commands, ``modbus`` the
gateway's; ``transfer`` builds download and upload on either; ``status`` reads a master's
state; ``boards`` keeps emulated boards between commands; ``program_files`` writes what
an upload gives back.
"""
