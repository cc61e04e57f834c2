"""The host side: reaching a master and doing ACF's and ASI_MON's work through it.

``connection.open_board`` is the one way to a master (``master.Master``): it chooses
among ``transports/`` (a PC2 board's registers and jobs, the gateway's Modbus),
``emulated/`` (emulated boards kept between commands, their lock and their actions) and
``live/`` (an emulated board a server keeps running), and hands back a ``pc2_master`` or
a ``modbus_master``. The commands' procedures stand beside it, written against that
master: ``transfer`` (download, upload), ``status``, ``commissioning``, ``forcing``,
``watch``, ``program_files`` (what an upload gives back) and the rest.
"""
