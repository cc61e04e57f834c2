"""``asictl monitor``: a live full-screen view of a master, ASI_MON and ASI_VIS in one.

``source`` reads and changes the master (no user-interface code: it is what the debugger
and other views can share); ``app`` is the Textual screen, loaded only by the command.
"""
