"""A live emulated board: master time follows the wall clock, and every command reaches it.

``asictl serve`` (and ``asictl gateway serve``, which puts Modbus in front of the same
board) keeps one emulated PC2 board running in real time and listens on a Unix socket in
the state directory, ``pc2-300h.sock`` (mode 0600: only its owner may talk to the board).
The other commands find the socket (``client.open_live``) and drive the board through it
with the very driver code a real board gets.

The parts: ``protocol`` (the messages both ends speak, and where the socket is),
``board`` (the board whose master time follows the wall clock), ``requests`` (what each
request does to the board), ``server`` (the socket: connections, sessions, the loop that
keeps master time), ``saver`` (every change of the board's state saved before it is
acknowledged), ``guard`` (the state folder, lock and socket put back when removed) and
``client`` (the commands' end: ``LiveClient``, the ``LivePort`` their driver runs on,
the board's emulated-only actions).
"""
