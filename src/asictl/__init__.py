"""asictl: a toolchain for the AS-i Control II mini-PLC.

The package is laid out along the pipeline a program travels (docs/architecture.md):
``grammar`` -> ``il`` (parse, load, check) -> ``codegen8051`` -> ``mcs51`` (assembler,
emulator) -> ``image`` -> ``board`` (the emulated master) / ``host`` (reaching a master)
-> ``cli``. ``build`` is the one way from any program file to an image; ``runtime`` is the
contract between compiled code and firmware; ``platform`` holds the hardware's facts.
"""

__version__ = "0.1.0"
