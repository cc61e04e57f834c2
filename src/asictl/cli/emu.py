"""``asictl emu``: run an Intel HEX image on the 8051 emulator, print the final state."""

from __future__ import annotations

import json

import click

from asictl.cli.hex_images import describe, program_image
from asictl.errors import ExitCode, UserError
from asictl.image.eeprom import ProgramImage
from asictl.mcs51.disassembler import decode, format_instruction
from asictl.mcs51.emulator import Emulator, StopReason
from asictl.mcs51.hexfile import read_hex
from asictl.runtime import layout
from asictl.runtime.runner import ProgramRunner

#: Safety net for programs that never reach --until (or when it is not given).
DEFAULT_MAX_INSTRUCTIONS = 100_000_000


class Address(click.ParamType[int]):
    """A code address as 8051 people write it: 0x100, 100h or 256."""

    name = "ADDR"

    def convert(
        self, value: int | str, param: click.Parameter | None, ctx: click.Context | None
    ) -> int:
        if isinstance(value, int):
            return value
        text = value.strip().lower()
        try:
            if text.startswith("0x"):
                number = int(text[2:], 16)
            elif text.endswith("h"):
                number = int(text[:-1], 16)
            else:
                number = int(text, 10)
        except ValueError:
            self.fail(f"{value!r} is not an address (write 0x100, 100h or 256)", param, ctx)
        if not 0 <= number <= 0xFFFF:
            self.fail(f"{value!r} is outside the 64 KB code space", param, ctx)
        return number


def _registers(emu: Emulator) -> str:
    regs = " ".join(f"{emu.r(n):02X}" for n in range(8))
    return (
        f"A={emu.a:02X} B={emu.b:02X} PSW={emu.psw:02X} SP={emu.sp:02X} "
        f"DPTR={emu.dptr:04X} R0-R7={regs}"
    )


def _trace(emu: Emulator, address: int) -> None:
    code = emu.code
    raw = bytes(code[(address + k) & 0xFFFF] for k in range(3))
    item = next(decode(raw, address))
    text = format_instruction(item)
    click.echo(
        f"{address:04X}  {item.data.hex(' ').upper():<8}  {text:<24}  {_registers(emu)}",
        err=True,
    )


def final_state(emu: Emulator, stopped: StopReason) -> dict[str, int | str | list[int]]:
    return {
        "pc": emu.pc,
        "a": emu.a,
        "b": emu.b,
        "psw": emu.psw,
        "sp": emu.sp,
        "dptr": emu.dptr,
        **{f"r{n}": emu.r(n) for n in range(8)},
        "iram": list(emu.iram),
        "instructions": emu.instructions,
        "cycles": emu.cycles,
        "stopped": stopped.value,
    }


def _program_cycle(name: str, image: ProgramImage, start: int | None) -> Emulator:
    """An emulator set up to run one cycle of an asictl image's program, as the firmware
    calls it: the code at its link address, firmware blocks that return at once, the
    final RET ending the run; inputs, flags and data are 0."""
    runner = ProgramRunner(image.loaded_program())
    runner.enter()
    if start is not None:
        runner.cpu.pc = start
    for line in describe(name, image):
        click.echo(line, err=True)
    click.echo(
        f"asictl: running one program cycle from {runner.cpu.pc:04X}h; it ends at the "
        f"return to {layout.CYCLE_END:04X}h ('stopped by trap')",
        err=True,
    )
    return runner.cpu


@click.command()
@click.argument("image", metavar="FILE.hex")
@click.option(
    "--start", type=Address(),
    help="Address to start at [default: 0; for an asictl program image its code base].",
)
@click.option(
    "--until",
    type=Address(),
    help="Stop before executing the instruction at this address (not checked for the "
    "first instruction, so --until may equal --start for a loop).",
)
@click.option(
    "--max-instructions",
    type=click.IntRange(min=0),
    default=DEFAULT_MAX_INSTRUCTIONS,
    show_default=True,
    help="Stop after this many instructions.",
)
@click.option(
    "--trace", is_flag=True, help="Print every instruction executed, with registers, to stderr."
)
def emu(
    image: str, start: int | None, until: int | None, max_instructions: int, trace: bool
) -> None:
    """Run an Intel HEX image (- for stdin) on the 8051 emulator; print the final state as JSON.

    The image is loaded into code memory; internal RAM, XDATA and the registers start
    at zero, SFRs at their reset values (SP=07h, P0-P3=FFh). Execution starts at
    --start and runs until --until or --max-instructions.

    The JSON object holds pc, a, b, psw, sp, dptr, r0-r7 of the active register bank,
    iram (all 256 bytes, as numbers), instructions, cycles (machine cycles: 12 clocks
    each on a standard 8051) and stopped (why the run ended).

    --trace prints one line per instruction to stderr: its address, bytes and
    disassembly, then the registers after it ran. Tracing is much slower than a plain
    run, which translates straight-line code into Python functions.

    An image written by 'asictl compile' (an asictl program image) is recognised: its
    program map goes to stderr, and one program cycle of its code runs at its link
    address, as the master's firmware calls it (firmware blocks return at once; inputs,
    flags and data are 0); the run ends when the program returns (stopped: 'stopped by
    trap'). 'asictl sim' runs a program with inputs and time.

    Addresses may be written 0x100, 100h or 256.

    Exit status: 0 the run ended as asked; 1 the program hit the undefined opcode A5h,
    or --until was given and not reached within --max-instructions; 2 bad usage or an
    unreadable or malformed HEX file.

    \b
    Examples:
      asictl compile demos/blink.asi -o blink.hex
      asictl emu blink.hex
    """
    hex_file = read_hex(image)
    for warning in hex_file.warnings:
        click.echo(f"asictl: warning: {warning}", err=True)
    hex_image = hex_file.image
    if hex_image.maxaddr() is not None and hex_image.maxaddr() > 0xFFFF:
        raise UserError(
            f"{image}: data beyond the 64 KB code space (up to {hex_image.maxaddr():#x})"
        )

    program = program_image(hex_image, image)
    if program is not None:
        emulator = _program_cycle(image, program, start)
    else:
        emulator = Emulator()
        for start_address, end_address in hex_image.segments():
            emulator.code[start_address:end_address] = hex_image.tobinstr(
                start=start_address, end=end_address - 1
            )
        emulator.pc = start or 0
    stopped = emulator.run(
        max_instructions=max_instructions, until=until, trace=_trace if trace else None
    )
    click.echo(json.dumps(final_state(emulator, stopped)))
    if until is not None and stopped is not StopReason.UNTIL:
        raise UserError(
            f"stopped at {emulator.pc:04X}h ({stopped.value}) before reaching {until:04X}h",
            ExitCode.FAILED,
        )
