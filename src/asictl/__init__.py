"""asictl: a toolchain for the AS-i Control II mini-PLC.

The package is laid out along the pipeline a program travels (docs/architecture.md):
``grammar`` -> ``il`` (parse, load, check) -> ``codegen8051`` -> ``mcs51`` (assembler,
emulator) -> ``image`` -> ``board`` (the emulated master) / ``host`` (reaching a master)
-> ``cli``. ``build`` is the one way from any program file to an image; ``runtime`` is the
contract between compiled code and firmware; ``platform`` holds the hardware's facts.

``LAYERS`` is that layout as the import rule: a package or module may import only what
stands in a lower layer (and itself); two in the same layer know nothing of each other.
``tests/test_layout.py`` holds every file to it, and docs/architecture.md is drawn from
it (``python3 tools/architecture.py``), so the picture cannot drift from the code.
"""

__version__ = "0.1.0"

#: The layers, lowest first: each a tuple of (name, what it holds). A name is a package
#: (a folder of ``src/asictl``) or a module there without its ``.py``.
LAYERS: tuple[tuple[tuple[str, str], ...], ...] = (
    (
        ("errors", "the exit codes and the user-error / bug split"),
        ("diagnostics", "`file:line:col: error: ...` with source line and caret, JSON, GitHub"),
        ("codes", "every diagnostic code, one enumeration per stage"),
        ("platform", "hardware facts, each defined once: the master, the PC2, the gateway"),
    ),
    (
        ("source", "reading DOS-era text (UTF-8, CP850, Latin-1; CR LF; Ctrl-Z)"),
        ("files", "writing outputs atomically, never over an input"),
        ("readers", "what users write by hand, read one way: TOML with places, durations, hints"),
    ),
    (("mcs51", "the 8051: one instruction table, assembler, disassembler, emulator"),),
    (
        ("runtime", "the contract between compiled programs and the firmware"),
        ("grammar", "the grammars of IL (`il.lark`) and conditions (`condition.lark`), data only"),
    ),
    (
        ("il", "parse, load, check, the analyses (W7xx), cross-reference, the oracle"),
        ("image", "the EEPROM image format only (header, code, program map, source)"),
    ),
    (
        ("codegen8051", "allocate, generate 8051 code, assemble, the compile listing"),
        ("board", "the emulated PC2 board: DPRAM, AS-i cycle, host commands, firmware"),
    ),
    (("build", "THE build API: any program file to diagnostics, program and image"),),
    (("observe", "the IL line behind the 8051's PC, operands, symbols, per-line traces"),),
    (("host", "reaching a master: emulated, /dev/port, Modbus; the live board"),),
    (
        ("gateway", "the emulated AS-i/Modbus gateway in front of a board"),
        ("sim", "scenarios in virtual time, traces"),
        ("fleet", "a plant's masters: the inventory, backup into git, verify, status"),
        ("opcua", "the OPC UA server on a live board (asyncua)"),
        ("web", "the web page and REST API on a live board (Starlette, uvicorn)"),
    ),
    (
        ("debug", "the IL debugger on a simulation, and on a live board for an editor"),
        ("monitor", "the full-screen live view (Textual)"),
        ("lsp", "the language server for editors"),
        ("testing", "the Python test API: a program on an emulated master, from code"),
        ("quality", "how good the tests are: mutants of programs against their scenarios"),
        ("prove", "properties proved on the symbolic cycle; two programs compared"),
        ("export", "the program as S7 STL, Structured Text or PLCopen XML for another PLC"),
    ),
    (("dap", "the debug adapter for editors: the Debug Adapter Protocol over debug/"),),
    (
        ("pytest_plugin", "scenario files as pytest tests"),
        ("cli", "the command line: options and output only"),
    ),
    (("__main__", "`python -m asictl`"),),
)
