"""The 8051 machine layer: one instruction-set table, assembler, disassembler, emulator."""
