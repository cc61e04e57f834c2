"""The live board's limits on its clients by default, apart from the server (and asyncio)
so the command line can show them without loading it: ``asictl bus`` and the other
commands of ``cli/live.py`` reach a served board as clients."""

#: Connections served at once by default (each command is one; a monitor is one).
DEFAULT_MAX_CONNECTIONS = 32
#: Seconds a session may go without a request by default before it is ended.
DEFAULT_SESSION_TIMEOUT_S = 10.0
#: Seconds a connection may go without a request by default before it is closed.
DEFAULT_IDLE_TIMEOUT_S = 60.0
#: Seconds a connection beyond the limit waits for a slot by default before it is told
#: the board is busy (a command takes a fraction of a second: the wait is for a turn).
DEFAULT_ADMIT_WAIT_S = 10.0
