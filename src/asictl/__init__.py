"""asictl: a toolchain for the AS-i Control II mini-PLC.

The package is laid out along the pipeline a program travels:
``grammar`` -> ``ast`` -> ``checks`` -> ``codegen`` -> ``mcs51`` (assembler, emulator)
-> ``image`` -> ``master`` / ``transport`` -> ``cli``.
"""

__version__ = "0.1.0"
