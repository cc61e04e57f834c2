"""The OPC UA server's limits on its clients, apart from the server (and asyncua) so the
command line can show them without the ``opcua`` extra."""

#: Client connections served at once by default (one that has not logged in included).
DEFAULT_MAX_CONNECTIONS = 32
#: Sessions at once by default (a session may outlive its connection until it times out).
DEFAULT_MAX_SESSIONS = 32
#: Seconds a connection may take by default to activate a session (log in).
DEFAULT_LOGIN_TIMEOUT_S = 5.0
#: The longest session time-out a client may ask for: a session whose client vanished
#: holds its place among the sessions no longer than this.
MAX_SESSION_TIMEOUT_S = 60.0
