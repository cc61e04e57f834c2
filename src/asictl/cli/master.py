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
from collections.abc import Callable
from pathlib import Path
from typing import Unpack

import click

from asictl.cli.board_options import BoardOptions, board_options, master_wait, open_master
from asictl.cli.guard_options import real_master_option, unconfirmed_format_option
from asictl.cli.options import lib_option, one_of
from asictl.cli.terminal import progress
from asictl.diagnostics import printable
from asictl.errors import ExitCode, UserError
from asictl.files import STDOUT, shown_name, write_output
from asictl.host.connection import cable_setup_slaves
from asictl.host.master import Master
from asictl.host.overwrite_guard import check_overwrite
from asictl.host.program_files import uploaded_files, write_files
from asictl.host.raw_image import holds_raw_program, is_asictl_image
from asictl.host.status import program_info, render
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
from asictl.source import check_readable


@click.command("download")
@click.argument("file", metavar="FILE.asi|FILE.hex", type=click.Path(dir_okay=False))
@board_options
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
    **board: Unpack[BoardOptions],
) -> None:
    """Store a program in the master's EEPROM and load it (ACF /d+).

    FILE is IL source (compiled against the entry points the master reports) or an image
    (.hex from 'asictl compile', or an uploaded file's [RAW] section). A program with
    errors is refused with the diagnostics 'asictl check' shows. The [SETUP] slaves go to
    LPS, PCD, PP and PI; the image is written block by block, the header block last, read
    back and compared; then the reset bit loads it, with the [OPTIONS] flags and the start
    flag as chosen. An interrupted download leaves no program a reset could start.

    The start flag stays as it was unless --start or --stop says otherwise: on a new
    master the program does not run until 'asictl start'.

    On a master that is not asictl's emulation the download first says what runs there
    and stops, unless --real-master and (for an image in asictl's format)
    --unconfirmed-format are given: back the master up first with 'asictl upload'.

    Exit status: 0 downloaded, 1 errors in the program or the master refused or failed,
    2 bad usage, an unreadable file or a corrupt board state.

    \b
    Examples:
      asictl download demos/blink.asi --start
      asictl download demos/counter.asi --port 304h
    """
    ctx = click.get_current_context()
    chosen = one_of(start=start, stop=stop, keep=keep)
    mode = StartMode(chosen or "keep")
    if raw or restore_setup:
        from asictl.cli import raw_images

        if not raw:
            raise click.UsageError("--restore-setup goes with --raw")
        if chosen:
            raise click.UsageError(f"--raw keeps the flags as they are (or restores them "
                                   f"with --restore-setup): --{chosen} does not apply")
        raw_image = raw_images.read_raw_file(file)
        with open_master(**board) as master:
            check_overwrite(
                master, "write this image byte for byte", real_master=real_master,
                unconfirmed_format=unconfirmed_format, asictl_image=is_asictl_image(raw_image),
            )
            raw_images.restore(master, file, raw_image, restore_setup=restore_setup)
        return
    from asictl.build import build_file  # the compiler: only a download loads it

    check_readable(file)  # before a board is opened: a missing one would be created
    with open_master(**board) as master:
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
        with progress(f"download {size} bytes", steps) as bar:
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
@board_options
@click.option(
    "-o", "--output", required=True, type=click.Path(dir_okay=False), metavar="FILE.asi",
    help="The source file to write (- for stdout); function-block files go beside it.",
)
@click.option(
    "--overwrite", is_flag=True, help="Replace files that exist with other content (ACF /o+).",
)
def upload_command(output: str, overwrite: bool, **board: Unpack[BoardOptions]) -> None:
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

    \b
    Examples:
      asictl download demos/blink.asi
      asictl upload -o copy.asi
    """
    from asictl.cli import raw_images

    with open_master(**board) as master:
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
    name: str, help_text: str, action: Callable[[Transport], int], what: str, *,
    needs_program: bool = False,
) -> click.Command:
    @click.command(name, help=help_text)
    @board_options
    @real_master_option
    def command(real_master: bool, **board: Unpack[BoardOptions]) -> None:
        with open_master(**board) as master:
            check_overwrite(master, what, real_master=real_master)
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
    "(normal operation, and no configuration error unless ignore_config_errors)." + _EXIT_STATUS
    + "\n\n\b\nExamples:\n  asictl download demos/blink.asi\n  asictl start",
    lambda transport: set_start(transport, start=True),
    "set the start flag (the control program starts driving the outputs)",
    needs_program=True,
)
stop_command = _control_command(
    "stop",
    "Clear the start flag: the control program stops and the master works as a plain "
    "AS-i master (ACF /s-)." + _EXIT_STATUS
    + "\n\n\b\nExamples:\n  asictl download demos/blink.asi --start\n  asictl stop",
    lambda transport: set_start(transport, start=False),
    "clear the start flag (the control program stops)",
)
@click.command("reset")
@board_options
@click.option(
    "--hardware", is_flag=True,
    help="Reset the board itself (PAGE bit 4 held 200 ms, AsiPc2Reset): a power-up.",
)
@real_master_option
def reset_command(hardware: bool, real_master: bool, **board: Unpack[BoardOptions]) -> None:
    """Set the reset bit: the master reloads the program from its EEPROM and clears the
    program's flags; the start flag stays as it is.

    With --hardware the PC2 board itself is reset, as the manual's AsiPc2Reset does: the
    PAGE register's bit 4 is held for 200 ms (the manual's minimum), then the board powers
    up: it writes its DPRAM anew, loses everything volatile (parameters, flags, the
    communication memory), copies the program from the EEPROM and starts up. The command
    waits until the board is found again and its start-up is over, and says what it came
    up with. A gateway has no such reset (exit 2).

    Exit status: 0 done, 1 the master refused or did not come back, 2 bad usage or a
    corrupt board state.

    \b
    Examples:
      asictl download demos/blink.asi
      asictl reset
      asictl reset --hardware
    """
    if hardware and board["modbus"] is not None:
        raise UserError(
            "--hardware resets a PC2 board through its PAGE register; a gateway has none "
            "(its Modbus restart, diagnostics code 1, only takes the master offline)",
            ExitCode.USAGE,
        )
    with open_master(**board) as master:
        check_overwrite(
            master, "reset the board (a power-up: everything volatile is lost)" if hardware
            else "reset the master (it reloads its program and clears the program's flags)",
            real_master=real_master,
        )
        if hardware:
            from asictl.host.hardware_reset import hardware_reset

            assert master.driver is not None  # every PC2 master has one
            powered = hardware_reset(master.driver, master_wait(master))
            click.echo(f"{master.name}: {powered.report()}", err=True)
        else:
            reset(master.transport)
        master.settle()
        state = master.summary()
    click.echo(f"{master.name}: {state}", err=True)
    _cable_hint(master, state)


@click.command("status")
@board_options
@click.option("--json", "as_json", is_flag=True, help="One JSON object on stdout.")
def status_command(as_json: bool, **board: Unpack[BoardOptions]) -> None:
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

    \b
    Examples:
      asictl download demos/blink.asi --start
      asictl status
      asictl status --json
    """
    with open_master(**board) as master:
        status = master.status()
    if as_json:
        click.echo(json.dumps(status.to_json(), indent=2))
    else:
        click.echo(printable(render(status)), nl=False)  # names from a symbol table
    if status.missing or status.unexpected or status.wrong_profile:
        _cable_hint(master, "config error")
