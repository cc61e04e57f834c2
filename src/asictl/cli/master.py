"""``asictl download|upload|start|stop|reset|status``: the PC2 host commands (docs/host.md).

The manual's ACF loader (8.2.6) with its switches as options: ``download`` is /d+,
``--start/--stop/--keep`` are /s+ /s- /s0, ``upload`` is /u+ and ``--overwrite`` /o+;
``status`` shows what ASI_MON's screen shows. A board is named by its I/O base
(``--port``, ACF's /i); by default it is an emulated board kept in the state directory.
``--modbus`` reaches the master through an AS-i/Modbus gateway instead: the same
procedures over ``ModbusTransport``.
"""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TypedDict, TypeVar, Unpack

import click
from click.core import ParameterSource

from asictl.build import build_file
from asictl.cli.guard_options import real_master_option, unconfirmed_format_option
from asictl.cli.options import lib_option
from asictl.cli.serial_options import serial_options, unit_option
from asictl.errors import ExitCode, UserError
from asictl.files import STDOUT, shown_name, write_output
from asictl.host.boards import IO_BACKENDS
from asictl.host.connection import MasterAddress, cable_setup_slaves, connect_master
from asictl.host.master import Master
from asictl.host.overwrite_guard import check_overwrite
from asictl.host.program_files import uploaded_files, write_files
from asictl.host.raw_image import holds_raw_program, is_asictl_image
from asictl.host.status import program_info, render
from asictl.host.target import DEFAULT_RETRIES, DEFAULT_TIMEOUT_S
from asictl.host.transfer import (
    StartMode,
    Transport,
    download,
    download_steps,
    linked_for,
    reset,
    set_start,
    upload,
    upload_head,
)
from asictl.platform.master import ControlFlag

_Callback = TypeVar("_Callback", bound=Callable[..., object])


class _BoardOptions(TypedDict):
    """The values of the options ``_board_options`` adds, as click passes them."""

    port: str
    io: str
    state_dir: str | None
    wait: bool
    modbus: str | None
    unit: int
    baud: str
    parity: str
    stopbits: str
    timeout: float
    retries: int


def _board_options(command: _Callback) -> _Callback:
    options = [
        click.option(
            "--port", default="300h", show_default=True,
            help="The board's I/O base: 300h, 304h, 308h, 30Ch, 320h, 324h, 328h or 32Ch "
            "(also written 0x300 or 300); auto: search them in this order and take the first "
            "board found, as the PC2 driver's AsiPc2Init(0) does.",
        ),
        click.option(
            "--io", type=click.Choice(IO_BACKENDS), default="emulated", show_default=True,
            help="emulated: an emulated board kept in the state directory; devport: a real "
            "board through /dev/port (needs root).",
        ),
        click.option(
            "--state-dir", type=click.Path(file_okay=False),
            help="Where emulated boards are kept [default: $ASICTL_STATE_DIR, else "
            "$XDG_STATE_HOME/asictl or ~/.local/state/asictl].",
        ),
        click.option(
            "--wait", is_flag=True,
            help="If another process (such as 'asictl gateway serve') holds the emulated "
            "board, wait for it instead of stopping with exit status 1.",
        ),
        click.option(
            "--modbus", metavar="URL|DEVICE",
            help="Go through an AS-i/Modbus gateway instead of a PC2 board: tcp://HOST[:PORT] "
            "(Modbus TCP), rtu+tcp://HOST[:PORT] (RTU through a device server) or a serial "
            "device such as /dev/ttyUSB0 (RTU). Excludes --port, --io, --state-dir and --wait.",
        ),
        unit_option("The gateway's Modbus slave address (with --modbus)."),
        serial_options("Serial --modbus"),
        click.option(
            "--timeout", type=click.FloatRange(0.01, 60), default=DEFAULT_TIMEOUT_S,
            show_default=True, help="--modbus: seconds to wait for each answer.",
        ),
        click.option(
            "--retries", type=click.IntRange(0, 20), default=DEFAULT_RETRIES,
            show_default=True,
            help="--modbus: how often a request is repeated after a time-out or CRC error.",
        ),
    ]
    for option in reversed(options):
        command = option(command)
    return command


_PC2_ONLY = ("port", "io", "state_dir", "wait")


def _address(
    port: str, io: str, state_dir: str | None, wait: bool, modbus: str | None, unit: int,
    baud: str, parity: str, stopbits: str, timeout: float, retries: int,
) -> MasterAddress:
    """The master the board options name; --modbus excludes the PC2 board's options."""
    if modbus is not None:
        ctx = click.get_current_context()
        clash = [
            f"--{option.replace('_', '-')}" for option in _PC2_ONLY
            if ctx.get_parameter_source(option) is not ParameterSource.DEFAULT
        ]
        if clash:
            raise UserError(f"--modbus and {', '.join(clash)} exclude each other")
    return MasterAddress(
        port, io, state_dir, modbus, unit, int(baud), parity, int(stopbits), timeout, retries,
        wait,
    )


@contextmanager
def _connect(**board: Unpack[_BoardOptions]) -> Iterator[Master]:
    """The master the options name. A board that did not exist yet is said so, whatever
    the command: a mistyped --state-dir or --port would otherwise go unnoticed."""
    with connect_master(
        _address(**board), notify=lambda message: click.echo(f"asictl: {message}", err=True)
    ) as master:
        if master.created:
            click.echo(
                f"asictl: note: there was no emulated board at {master.name} in the state "
                "directory: a new, empty one was created (is ASICTL_STATE_DIR or --state-dir "
                "the one you meant?)",
                err=True,
            )
        yield master


@contextmanager
def _progress(label: str, blocks: int) -> Iterator[Callable[[int], None]]:
    """A progress bar on stderr (only its label when stderr is not a terminal)."""
    with click.progressbar(
        length=blocks, label=label, file=sys.stderr, show_eta=False,
    ) as bar:
        yield bar.update


@click.command("download")
@click.argument("file", metavar="FILE.asi|FILE.hex", type=click.Path(dir_okay=False))
@_board_options
@click.option("--start", "start", is_flag=True, help="Start the program (ACF /s+).")
@click.option("--stop", "stop", is_flag=True, help="Stop the program (ACF /s-).")
@click.option(
    "--keep", "keep", is_flag=True, help="Leave the start flag as it is (ACF /s0) [default].",
)
@click.option(
    "--raw", is_flag=True,
    help="FILE.hex is a raw image ('asictl upload' of a program not in asictl's format): "
    "write it byte for byte, read it back and compare, then reset the master.",
)
@click.option(
    "--restore-setup", is_flag=True,
    help="With --raw: first write the configuration (LPS, PCD, PP) and the AS-i Control "
    "flags from the record beside FILE.hex (FILE.json).",
)
@real_master_option
@unconfirmed_format_option
@lib_option
def download_command(
    file: str, start: bool, stop: bool, keep: bool, raw: bool, restore_setup: bool,
    real_master: bool, unconfirmed_format: bool, lib: tuple[str, ...],
    **board: Unpack[_BoardOptions],
) -> None:
    """Store a program in the master's EEPROM and load it (ACF /d+).

    FILE is IL source (compiled against the entry points the master reports) or an image
    (.hex from 'asictl compile', or an uploaded file's [RAW] section). A program with
    errors is refused with the diagnostics 'asictl check' shows. The [SETUP] slaves go to
    LPS, PCD, PP and PI; the image is written block by block, the header block last, read
    back and compared; then the reset bit loads it, with the [OPTIONS] flags and the start
    flag as chosen. An interrupted download leaves no program a reset could start.

    On a master that is not asictl's emulation the download first says what runs there
    and stops, unless --real-master and (for an image in asictl's format)
    --unconfirmed-format are given: back the master up first with 'asictl upload'.

    Exit status: 0 downloaded, 1 errors in the program or the master refused or failed,
    2 bad usage, an unreadable file or a corrupt board state.
    """
    ctx = click.get_current_context()
    chosen = [name for name, on in (("start", start), ("stop", stop), ("keep", keep)) if on]
    if len(chosen) > 1:
        raise click.UsageError(
            " and ".join(f"--{name}" for name in chosen) + " contradict each other: give one"
        )
    mode = StartMode(chosen[0] if chosen else "keep")
    if raw or restore_setup:
        from asictl.cli import raw_images

        if not raw:
            raise click.UsageError("--restore-setup goes with --raw")
        if chosen:
            raise click.UsageError(f"--raw keeps the flags as they are (or restores them "
                                   f"with --restore-setup): --{chosen[0]} does not apply")
        raw_image = raw_images.read_raw_file(file)
        with _connect(**board) as master:
            check_overwrite(
                master, "write this image byte for byte", real_master=real_master,
                unconfirmed_format=unconfirmed_format, asictl_image=is_asictl_image(raw_image),
            )
            raw_images.restore(master, file, raw_image, restore_setup=restore_setup)
        return
    with _connect(**board) as master:
        check_overwrite(master, "download an image in asictl's format", real_master=real_master,
                        unconfirmed_format=unconfirmed_format, asictl_image=True)
        transport = master.transport
        entry_points = transport.entry_points()
        built = build_file(file, entry_points=entry_points, lib=lib)
        click.echo(built.render(), nl=False, err=True)
        image = built.image
        if built.has_errors or image is None:
            ctx.exit(int(ExitCode.FAILED))
        linked_for(image, entry_points)
        if built.compiled is not None and image.source_left_out:
            click.echo(
                "asictl: warning: the source text does not fit in the EEPROM and is left "
                "out; an upload will give [RAW] records instead of the program text",
                err=True,
            )
        cable_setup_slaves(master, image)
        size = len(image.to_bytes())
        steps = download_steps(size, transport.block_size)
        with _progress(f"download {size} bytes", steps) as bar:
            download(transport, image, start=mode, progress=bar)
        master.settle()
        state = master.summary()
        flags = transport.control_flags()
    click.echo(f"{master.name}: downloaded {file} ({size} bytes, identity "
               f"{image.identity_hex}); {state}", err=True)
    if mode is StartMode.KEEP and not flags & (
        ControlFlag.START | ControlFlag.CONTROL_ACTIVE
    ):
        click.echo(
            "asictl: note: the start flag is off (the download leaves it as it was): start "
            "the program with 'asictl start' and the same board options, or download with "
            "--start (auto_start only restarts a program the master stopped)",
            err=True,
        )
    _cable_hint(master, state)


@click.command("upload")
@_board_options
@click.option(
    "-o", "--output", required=True, type=click.Path(dir_okay=False), metavar="FILE.asi",
    help="The source file to write (- for stdout); function-block files go beside it.",
)
@click.option(
    "--overwrite", is_flag=True, help="Replace files that exist with other content (ACF /o+).",
)
def upload_command(output: str, overwrite: bool, **board: Unpack[_BoardOptions]) -> None:
    """Read the program back from the master into a source file (ACF /u+).

    The image is read from the EEPROM and checked (CRC). If it carries its source, the
    exact files it was compiled from are written: the main file as FILE.asi, the
    function-block files beside it, and the symbol table the download carried as
    FILE.symbols.toml. Otherwise FILE.asi gets [OPTIONS], [SETUP] and the
    image itself as [RAW] records. Either way, downloading FILE.asi stores the identical
    image again (the file names are part of a program's identity: keep the main file's
    name). Files that exist with other content are left alone (and nothing is written)
    unless --overwrite is given. Names of function-block files that are not plain,
    printable file names stop the upload before anything is written.

    A program not in asictl's format (one the vendor's tools loaded) is written byte for
    byte instead: the EEPROM from 0 to its last non-blank line as an Intel HEX file
    (FILE.hex, beside FILE.asi if -o names one) and FILE.json, what the master reported
    (name, version, software letters, flags, configuration). 'asictl download FILE.hex
    --raw' writes it back, 'asictl verify FILE.hex' compares it.

    Exit status: 0 uploaded, 1 no valid program in the master, a file not overwritten or
    a failed command, 2 bad usage or a corrupt board state.
    """
    from asictl.cli import raw_images

    with _connect(**board) as master:
        head = upload_head(master.transport)
        raw = None
        if holds_raw_program(head):
            raw = raw_images.read_raw(master, raw_images.hex_output(output).name)
        else:
            image = upload(master.transport, head)
    if raw is not None:
        raw_images.write_raw(master, raw, output, overwrite=overwrite)
        return
    files = uploaded_files(image, output)
    source = "its source" if image.source else "[RAW] records (the image carries no source)"
    if output == STDOUT:
        if image.symbols() is not None:
            files.pop()  # the symbol table: a file beside the program, none on stdout
            click.echo(f"{master.name}: note: the program's symbol table is written only "
                       "beside a file (-o FILE.asi)", err=True)
        if len(files) > 1:
            raise UserError(
                f"the program has {len(files) - 1} function-block file(s), which cannot go to "
                "standard output: give -o FILE.asi to write them beside it"
            )
        write_output(STDOUT, files[0][1])
        click.echo(f"{master.name}: uploaded {image.identity_hex} as {source}", err=True)
        return
    written = write_files(files, overwrite=overwrite)
    click.echo(
        f"{master.name}: uploaded {image.identity_hex} as {source}; "
        + (f"wrote {', '.join(shown_name(str(p)) for p in written)}" if written
           else "files already up to date"),
        err=True,
    )
    main_name = next(iter(image.program_sources()), None)
    if main_name is not None and main_name != Path(output).name:
        click.echo(
            f"asictl: note: the program's main file was '{shown_name(main_name)}'; compiled "
            f"as '{shown_name(Path(output).name)}' it gets another identity",
            err=True,
        )


def _master_wait(master: Master) -> Callable[[float], None]:
    """How a command lets master time pass: at once on a board loaded for the command,
    in real time on a live or real one."""
    if master.action is not None:
        return master.action.wait_ms
    return lambda ms: time.sleep(ms / 1000)


def _cable_hint(master: Master, summary: str) -> None:
    """On an emulated board a configuration error is usually a cable that does not match
    the program yet: say how to plug in the [SETUP]'s slaves."""
    if master.action is not None and "config error" in summary:
        click.echo(
            f"{master.name}: hint: the emulated AS-i cable does not match the projected "
            "configuration; 'asictl bus match' plugs in the [SETUP]'s slaves "
            "('asictl bus' shows the cable)",
            err=True,
        )


def _control_command(
    name: str, help_text: str, action: Callable[[Transport], int], *, needs_program: bool = False
) -> click.Command:
    @click.command(name, help=help_text)
    @_board_options
    def command(**board: Unpack[_BoardOptions]) -> None:
        with _connect(**board) as master:
            if needs_program and not program_info(master.transport).valid:
                raise UserError(
                    f"{master.name}: no valid program in the master to start "
                    "(download one first)", ExitCode.FAILED,
                )
            action(master.transport)
            master.settle()
            state = master.summary()
        click.echo(f"{master.name}: {state}", err=True)
        _cable_hint(master, state)

    return command


_EXIT_STATUS = (
    "\n\nExit status: 0 done, 1 the master refused or did not answer, 2 bad usage or a "
    "corrupt board state."
)

start_command = _control_command(
    "start",
    "Set the start flag: the control program runs as soon as the master permits "
    "(normal operation, and no configuration error unless ignore_config_errors)." + _EXIT_STATUS,
    lambda transport: set_start(transport, start=True),
    needs_program=True,
)
stop_command = _control_command(
    "stop",
    "Clear the start flag: the control program stops and the master works as a plain "
    "AS-i master (ACF /s-)." + _EXIT_STATUS,
    lambda transport: set_start(transport, start=False),
)
@click.command("reset")
@_board_options
@click.option(
    "--hardware", is_flag=True,
    help="Reset the board itself (PAGE bit 4 held 200 ms, AsiPc2Reset): a power-up.",
)
def reset_command(hardware: bool, **board: Unpack[_BoardOptions]) -> None:
    """Set the reset bit: the master reloads the program from its EEPROM and clears the
    program's flags; the start flag stays as it is.

    With --hardware the PC2 board itself is reset, as the manual's AsiPc2Reset does: the
    PAGE register's bit 4 is held for 200 ms (the manual's minimum), then the board powers
    up: it writes its DPRAM anew, loses everything volatile (parameters, flags, the
    communication memory), copies the program from the EEPROM and starts up. The command
    waits until the board is found again and its start-up is over, and says what it came
    up with. A gateway has no such reset (exit 2).

    \b
    Example:
      asictl reset --hardware --port 300h

    Exit status: 0 done, 1 the master refused or did not come back, 2 bad usage or a
    corrupt board state.
    """
    if hardware and board["modbus"] is not None:
        raise UserError(
            "--hardware resets a PC2 board through its PAGE register; a gateway has none "
            "(its Modbus restart, diagnostics code 1, only takes the master offline)",
            ExitCode.USAGE,
        )
    with _connect(**board) as master:
        if hardware:
            from asictl.host.hardware_reset import hardware_reset

            assert master.driver is not None  # every PC2 master has one
            powered = hardware_reset(master.driver, _master_wait(master))
            click.echo(f"{master.name}: {powered.report()}", err=True)
        else:
            reset(master.transport)
        master.settle()
        state = master.summary()
    click.echo(f"{master.name}: {state}", err=True)
    _cable_hint(master, state)


@click.command("status")
@_board_options
@click.option("--json", "as_json", is_flag=True, help="One JSON object on stdout.")
def status_command(as_json: bool, **board: Unpack[_BoardOptions]) -> None:
    """Show the master's state: what ASI_MON's screens showed.

    Phase and mode, execution control flags, the slave lists LPS/LDS/LAS/LCS/LOS,
    configuration errors (projected slaves missing, unprojected ones present, wrong I/O
    or ID code), the control program (running or why not), its AS-i Control flags, the
    program image in the EEPROM (identity, size, whether it is valid), the program cycle
    times, the hi-flags, the program's timers and counters (emulated boards), per slave
    its input and output data, configuration (PCD/CDI), parameters (PP/PI), lists and
    error counter, and the flag bytes F0..F127. A gateway shows no cycle times, program
    status, LCS, LOS or timers (its control state and stop reason are derived from the
    flags, as docs/host.md says). docs/commissioning.md has the JSON schema.

    Exit status: 0 shown, 1 the master did not answer, 2 bad usage or a corrupt board state.
    """
    with _connect(**board) as master:
        status = master.status()
    if as_json:
        click.echo(json.dumps(status.to_json(), indent=2))
    else:
        click.echo(render(status), nl=False)
    if status.missing or status.unexpected or status.wrong_profile:
        _cable_hint(master, "config error")
