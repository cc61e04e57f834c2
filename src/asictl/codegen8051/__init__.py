"""IL -> 8051 assembly: memory allocation, instruction selection, the runtime contract.

``layout`` holds the addresses both sides of the contract agree on (docs/runtime.md),
``allocate`` places the program's data, ``emitter`` writes the assembly.
"""
