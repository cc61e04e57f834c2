"""IL -> 8051 code: memory allocation, instruction selection, the output stream.

``allocate`` places the program's data, ``emitter`` selects instructions as objects and
``generate`` walks the program with it, ``stream`` turns the objects into bytes, listing
lines and the line map, ``compiler`` runs the steps, ``listing`` writes the listing.
"""
