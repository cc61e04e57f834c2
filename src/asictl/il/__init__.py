"""The IL front end: source text -> checked program.

``parser`` (with ``transformer`` and ``syntax_errors``) reads one file into an ``ast``
module; ``loader`` follows function-block calls into their files; ``checks`` reports
every semantic problem of the whole program. ``reference`` is an independent interpreter
of the language, the test oracle the compiled code is held against.
"""
