"""Reading what users write by hand, one way for every file and option: durations with
their units (``units``), a slave's profile (``profile``)."""
